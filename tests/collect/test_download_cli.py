"""``sondalog logger download`` against real served loggers over TCP (issue 13, download)."""

from __future__ import annotations

import asyncio
import csv
import json
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from served_logger import CLI, configure, download, sampling_logger, serving

from sondalog.client.records import parse_row
from sondalog.collect.to_file import download_to_file


def _expected(rows: list[str], logger: str = "000001") -> list[tuple[str, ...]]:
    """The long-form lines the record's rows must give (logger, time, counter, ch, value)."""
    out = []
    for line in rows:
        row = parse_row(line)
        stamp = row.time.isoformat()
        if row.text is not None:
            out.append((logger, stamp, str(row.counter), str(row.type), "0", "", row.text))
            continue
        for ch, value in enumerate(row.values, start=1):
            if value is not None:
                out.append(
                    (logger, stamp, str(row.counter), str(row.type), str(ch), repr(value), "")
                )
    return out


def _csv(path: Path) -> list[list[str]]:
    with path.open(newline="") as f:
        return list(csv.reader(f))


def _held(path: Path) -> list[tuple[str, ...]]:
    return [tuple(line[:7]) for line in _csv(path)[1:]]


def test_resume_appends_exactly_the_new_rows(tmp_path: Path) -> None:
    out = tmp_path / "data.csv"
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.4)
        first = download(served.url, str(out) and out, "--tz", "Europe/Prague")
        assert first.returncode == 0, first.stderr
        assert first.stderr == ""  # quiet when not on a terminal
        held = len(_csv(out))
        served.ask("write text/a, text row/")
        time.sleep(0.4)
        second = download(served.url, out, "--tz", "Europe/Prague")
        assert second.returncode == 0, second.stderr
        assert len(_csv(out)) > held
        served.ask("write channel sampling period 000000 000000")
        third = download(served.url, out, "--tz", "Europe/Prague")
        assert third.returncode == 0, third.stderr
        rows = served.record()
        again = download(served.url, out)
        assert again.returncode == 0 and len(_csv(out)) == len(_expected(rows)) + 1
    lines = _csv(out)
    assert ",".join(lines[0]) == "logger,time,counter,type,channel,value,text,name,unit,utc"
    assert _held(out) == _expected(rows)  # in order, nothing twice, nothing lost
    assert any(line[6] == "a, text row" and line[4] == "0" for line in lines[1:])
    supply = next(line for line in lines[1:] if line[4] == "1")
    level = next(line for line in lines[1:] if line[4] == "2")
    assert (supply[7], supply[8], level[7], level[8]) == ("Supply", "V", "Level", "m")
    local = datetime.fromisoformat(supply[1])
    assert datetime.fromisoformat(supply[9].replace("Z", "+00:00")) == local.replace(
        tzinfo=UTC
    ) - timedelta(hours=1)  # Europe/Prague in March: CET


def test_jsonl_and_parquet_hold_the_same_readings(tmp_path: Path) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.3)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()
        for name in ("data.csv", "data.jsonl", "data.parquet"):
            done = download(served.url, tmp_path / name)
            assert done.returncode == 0, done.stderr
    expected = _expected(rows)
    records = [json.loads(line) for line in (tmp_path / "data.jsonl").read_text().splitlines()]
    assert list(records[0])[:6] == ["logger", "time", "counter", "type", "channel", "value"]
    assert [
        (r["logger"], r["time"], str(r["counter"]), str(r["type"]), str(r["channel"]))
        for r in records
    ] == [e[:5] for e in expected]
    table = pq.read_table(tmp_path / "data.parquet").to_pylist()
    assert [(r["time"], r["channel"], r["value"]) for r in table] == [
        (r["time"], r["channel"], r["value"]) for r in records
    ]


def test_refuses_a_file_that_is_not_ours(tmp_path: Path) -> None:
    notes = tmp_path / "notes.csv"
    notes.write_text("date,temperature\n2007-01-01,3\n")
    other = tmp_path / "other.csv"
    other.write_text(
        "logger,time,counter,type,channel,value,text,name,unit,utc\n"
        "999999,2007-03-01T00:00:00,0,1,1,12.0,,Supply,V,\n"
    )
    with serving(tmp_path) as served:
        for path, words in ((notes, "not a sondalog CSV export"), (other, "'999999'")):
            before = path.read_bytes()
            done = download(served.url, path)
            assert done.returncode == 2, done.stderr
            assert words in done.stderr
            assert path.read_bytes() == before
        bad = download(served.url, tmp_path / "data.xlsx")
        assert bad.returncode == 2 and "use .csv, .jsonl or .parquet" in bad.stderr


def test_unreachable_logger(tmp_path: Path) -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    done = download(f"tcp://127.0.0.1:{port}", tmp_path / "x.csv")
    assert done.returncode == 1
    assert "cannot reach the logger" in done.stderr


@pytest.fixture
def garbage_server() -> Iterator[int]:
    """A TCP server that answers every line with noise and never with OK."""
    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def run() -> None:
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            with conn:
                conn.settimeout(3)
                try:
                    while conn.recv(1024):
                        conn.sendall(b"\x8f\x91#@!garbage\xfe\r\n")
                except OSError:
                    pass

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join()
    server.close()


def test_a_logger_answering_garbage(tmp_path: Path, garbage_server: int) -> None:
    out = tmp_path / "x.csv"
    done = download(f"tcp://127.0.0.1:{garbage_server}", out, "--timeout", "0.5")
    assert done.returncode == 1
    assert "garbage" in done.stderr or "incomplete answer" in done.stderr
    assert _csv(out) == [
        ["logger", "time", "counter", "type", "channel", "value", "text", "name", "unit", "utc"]
    ]


def test_ctrl_c_leaves_a_valid_file_and_the_next_run_resumes(tmp_path: Path) -> None:
    out = tmp_path / "data.csv"
    with sampling_logger(tmp_path, 200) as served:
        configure(served)
        time.sleep(0.5)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()  # ~100 rows, ~3 kB: ~3 s at 9600 baud
    with serving(tmp_path, "--line-rate") as served:
        proc = subprocess.Popen(
            [*CLI, "logger", "download", served.url, "-o", str(out)],
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 20
        while (not out.exists() or out.read_text().count("\n") < 2) and time.monotonic() < deadline:
            time.sleep(0.05)  # the first chunk is in the file
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 130, err
        assert "interrupted" in err and "run again to resume" in err
        part = _held(out)
        assert 0 < len(part) < len(_expected(rows))
        assert out.read_bytes().endswith(b"\n")
        assert part == _expected(rows)[: len(part)]
        done = download(served.url, out)
        assert done.returncode == 0, done.stderr
    assert _held(out) == _expected(rows)


def test_overwritten_rows_are_reported_as_a_gap(tmp_path: Path) -> None:
    out = tmp_path / "data.csv"
    with sampling_logger(tmp_path, 20) as served:
        served.ask("write file record size 512")  # about 16 rows of two channels
        configure(served)
        time.sleep(0.5)
        first = download(served.url, out)
        assert first.returncode == 0 and "gap" not in first.stderr
        cursor = _csv(out)[-1][1]
        time.sleep(1.5)  # ~30 more rows: the record wraps past the cursor
        served.ask("write channel sampling period 000000 000000")
        oldest = parse_row(served.record()[0])
        second = download(served.url, out)
    assert second.returncode == 0, second.stderr
    lost = int((oldest.time - datetime.fromisoformat(cursor)).total_seconds()) - 1
    assert lost > 5
    assert "gap" in second.stderr
    assert f"about {lost} rows lost between {cursor}" in second.stderr
    assert oldest.time.isoformat() in second.stderr


async def _corrupting_proxy(target: int, flips: list[int]) -> asyncio.Server:
    """Forward TCP to the logger, changing one digit of the first long answer."""

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_r, up_w = await asyncio.open_connection("127.0.0.1", target)

        async def pump(src: asyncio.StreamReader, dst: asyncio.StreamWriter, down: bool) -> None:
            while data := await src.read(65536):
                if down and not flips and len(data) > 300:
                    at = data.index(b"2007", 200) + 15  # a digit of a row's time stamp
                    data = data[:at] + bytes([data[at] ^ 0x01]) + data[at + 1 :]
                    flips.append(at)
                dst.write(data)
                await dst.drain()
            dst.close()

        await asyncio.gather(pump(reader, up_w, False), pump(up_r, writer, True))

    return await asyncio.start_server(handle, "127.0.0.1", 0)


def test_a_corrupted_chunk_is_read_again(tmp_path: Path) -> None:
    with sampling_logger(tmp_path, 50) as served:
        configure(served)
        time.sleep(0.5)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()

        async def go() -> tuple[int, list[int]]:
            flips: list[int] = []
            proxy = await _corrupting_proxy(served.port, flips)
            port = proxy.sockets[0].getsockname()[1]
            done = await download_to_file(f"tcp://127.0.0.1:{port}", tmp_path / "d.csv")
            proxy.close()
            return done.rereads, flips

        rereads, flips = asyncio.run(go())
    assert flips and rereads == 1
    assert _held(tmp_path / "d.csv") == _expected(rows)


def test_download_over_a_paced_pty(tmp_path: Path) -> None:
    link = tmp_path / "ala1"
    out = tmp_path / "data.jsonl"
    with sampling_logger(tmp_path, 50, "--pty", str(link)) as served:
        configure(served)
        time.sleep(0.3)
        served.ask("write channel sampling period 000000 000000")
        rows = served.record()
        done = download(f"serial://{link}?baud=9600", out)
        assert done.returncode == 0, done.stderr
        again = download(f"serial://{link}?baud=9600", out)
        assert again.returncode == 0, again.stderr
    records = [json.loads(line) for line in out.read_text().splitlines()]
    assert [(r["time"], str(r["counter"]), str(r["channel"])) for r in records] == [
        (e[1], e[2], e[4]) for e in _expected(rows)
    ]
