"""Replay end to end (issue 23): a real session with a virtual logger is recorded by the
client's ``--trace`` endpoint, served back by ``logger replay``, and the same client calls
get the same answers; a host that does something else is told, and the deviation reported."""

from __future__ import annotations

import asyncio
import os
import select
import subprocess
import sys
from pathlib import Path

from sondalog.app.logger import start_logger
from sondalog.app.replay import load_replay, start_replay
from sondalog.client import Ala1Client, Request, Response, Status, parse_url
from sondalog.client.tables import pull_files, push
from sondalog.client.trace import TracedEndpoint, TraceWriter
from sondalog.io.clock import RealClock

SONDALOG = [sys.executable, "-m", "sondalog"]
#: Two conversion tables (§10.2): their upload carries LF bytes in XMODEM blocks.
TABLES = {
    "tabulka1": b"100.8 550.9\n351.65 1000\n893 1790.53\n",
    "tabulka2": b"3\n100.8 550.9\n351.65 1000\n893 1790.53\n4\n100.7 560\n351 1008\n",
}


async def _session(client: Ala1Client) -> tuple[list[Response], tuple[bytes, bytes]]:
    """What a host program does: plain, checked and summed commands, a refused one, a
    pipeline, a write, and XMODEM transfers both ways (the table areas, §6.16)."""
    answers = [
        await client.command("read i version"),
        await client.command("read i snumber", check=True),
        await client.command("read date", sum=True, crcsum=True),
        await client.command("read nonsense"),
        await client.command("write i description/Replay test/"),
    ]
    answers += await client.pipeline(
        ["read i description", Request("read com speed", crcsum=True), "read i version"]
    )
    partition = "write file record size 983040 write file list size 256 write file data size 51200"
    answers.append(await client.command(partition))
    await push(client, TABLES)
    tables = await pull_files(client)
    answers.append(await client.command("read i version"))
    return answers, tables


async def _record(tmp_path: Path, trace: Path) -> tuple[list[Response], tuple[bytes, bytes]]:
    logger = await start_logger(tmp_path / "state", RealClock(), ("127.0.0.1", 0))
    try:
        host, port = logger.servers[0].address
        writer = TraceWriter(trace, f"tcp://{host}:{port}")
        try:
            client = await Ala1Client.connect(
                TracedEndpoint(parse_url(f"tcp://{host}:{port}"), writer), timeout=5
            )
            try:
                return await _session(client)
            finally:
                await client.close()
        finally:
            writer.close()
    finally:
        await logger.close()


def test_a_recorded_session_replays_identically(tmp_path: Path) -> None:
    trace = tmp_path / "session.trace"
    recorded, tables = asyncio.run(_record(tmp_path, trace))
    assert [r.status for r in recorded].count(Status.ERROR) == 1  # read nonsense
    assert recorded[5].lines == ("Replay test",)
    assert os.stat(trace).st_mode & 0o777 == 0o600

    async def replay() -> None:
        device = load_replay(trace)
        served = await start_replay(device, ("127.0.0.1", 0))
        try:
            async with await Ala1Client.connect(served.url, timeout=5) as client:
                assert await _session(client) == (recorded, tables)
                assert device.deviations == []
                # now something the recording does not hold: an error the host sees
                other = await client.command("read i snumber")
            assert other.status is Status.ERROR
            assert other.raw == b"read i snumber\r\nERROR\r\n"
            await asyncio.sleep(0.05)  # the server notices the close
            assert [d.kind for d in device.deviations] == ["beyond"]
        finally:
            await served.close()

    asyncio.run(replay())


def test_strict_replay_tells_the_host_what_it_expected(tmp_path: Path) -> None:
    trace = tmp_path / "session.trace"
    asyncio.run(_record(tmp_path, trace))

    async def deviate() -> None:
        device = load_replay(trace)
        served = await start_replay(device, ("127.0.0.1", 0))
        try:
            async with await Ala1Client.connect(served.url, timeout=5) as client:
                assert (await client.command("read i version")).lines == ("2.10",)
                wrong = await client.command("read i snumber")  # without its check
                assert wrong.status is Status.ERROR
                assert device.deviations[0].describe() == (
                    "line 1: exchange 2: expected 'check 1377 read i snumber', got 'read i snumber'"
                )
        finally:
            await served.close()
        assert [(d.kind, d.index) for d in device.deviations] == [
            ("different", 1),
            ("missing", 1),
        ]

    asyncio.run(deviate())


def _start(args: list[str]) -> tuple[subprocess.Popen[bytes], str]:
    proc = subprocess.Popen([*SONDALOG, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 15)
    line = proc.stdout.readline().decode() if ready else ""
    if not line.startswith("listening on "):
        proc.kill()
        raise AssertionError(f"did not start: {line!r} {proc.communicate()[1]!r}")
    return proc, "tcp://" + line.removeprefix("listening on ").strip()


def _term(url: str, commands: str, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*SONDALOG, "term", url, *extra],
        input=commands,
        capture_output=True,
        text=True,
        timeout=60,
    )


SCRIPT = "read i version\nwrite i description/from term/\nread i description\nread nonsense\n"


def test_term_trace_and_logger_replay_from_the_command_line(tmp_path: Path) -> None:
    trace = tmp_path / "term.trace"
    logger, url = _start(["logger", "serve", "--listen", "127.0.0.1:0", "--state", str(tmp_path)])
    try:
        live = _term(url, SCRIPT, "--trace", str(trace))
    finally:
        logger.terminate()
        logger.communicate(timeout=10)
    assert live.returncode == 1  # "read nonsense" was refused
    assert "from term" in live.stdout
    assert trace.read_text().startswith("# sondalog line trace 1: tcp://127.0.0.1:")

    replay, replay_url = _start(
        ["logger", "replay", str(trace), "--listen", "127.0.0.1:0", "--once"]
    )
    replayed = _term(replay_url, SCRIPT)
    _, err = replay.communicate(timeout=20)
    assert (replayed.stdout, replayed.returncode) == (live.stdout, 1)
    assert replay.returncode == 0, err
    assert "4 exchanges answered from the recording of 4, 0 deviations" in err.decode()

    replay, replay_url = _start(
        ["logger", "replay", str(trace), "--listen", "127.0.0.1:0", "--once"]
    )
    other = _term(replay_url, "read i version\nread i snumber\n")
    _, err = replay.communicate(timeout=20)
    assert "the logger answered ERROR to 'read i snumber'" in other.stderr
    assert replay.returncode == 1
    report = err.decode()
    assert "deviation: line 1: exchange 2: expected 'write i description/from term/'" in report
    assert "exchange 2 'write i description/from term/' and the 2 after it never sent" in report
    assert "1 exchanges answered from the recording of 4, 2 deviations" in report


def test_a_bad_trace_is_refused_with_its_line(tmp_path: Path) -> None:
    trace = tmp_path / "bad.trace"
    trace.write_text("# a trace\n2026-12-01T22:10:00.123Z  host<logger  x\n")
    done = subprocess.run(
        [*SONDALOG, "logger", "replay", str(trace), "--listen", "127.0.0.1:0"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2
    assert f"{trace}:2: expected 'TIME  DIRECTION  BYTES'" in done.stderr


def test_lenient_replay_answers_in_any_order(tmp_path: Path) -> None:
    trace = tmp_path / "session.trace"
    recorded, _ = asyncio.run(_record(tmp_path, trace))

    async def lenient() -> None:
        device = load_replay(trace, lenient=True)
        served = await start_replay(device, ("127.0.0.1", 0))
        try:
            async with await Ala1Client.connect(served.url, timeout=5) as client:
                description = await client.command("read  i description")  # spaces normalised
                version = await client.command("read i version")
                unknown = await client.command("read i fw")
        finally:
            await served.close()
        assert description.lines == ("Replay test",)
        assert version == recorded[0]
        assert (unknown.status, unknown.raw) == (Status.ERROR, b"read i fw\r\nERROR\r\n")
        assert [(d.kind, d.got) for d in device.deviations] == [("unknown", "read i fw")]

    asyncio.run(lenient())
