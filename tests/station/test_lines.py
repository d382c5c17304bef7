"""plan and apply over the other lines the client knows (issue 22): a serial line (the pty of
a served logger), a GSM data call (gsm://) and the GPRS port of the served GSM network."""

from __future__ import annotations

import asyncio
import os
import re
import select
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from station_helpers import ask, explain_text, served

from sondalog.client.station_apply import apply, make_plan
from sondalog.client.station_file import read_station
from sondalog.config import loads

ROOT = Path(__file__).resolve().parents[2]
MODEM, PHONE = "+420600000001", "+420700000001"


def test_over_a_serial_line(tmp_path: Path) -> None:
    station = read_station(
        loads('[channel.2]\nname = "Voda"\nsampling_period = "000100"\n[com]\nspeed = 115200\n')
    )

    async def run() -> None:
        link = tmp_path / "ala1"
        async with served(tmp_path / "s", "1.16", ptys=[link]) as lg:
            assert await ask(lg.url, ["write com speed 115200"]) == ["OK"]
            url = f"serial://{link}?baud=115200"
            assert [c.name for c in (await make_plan(url, station)).changes] == [
                "channel 2 name",
                "channel 2 sampling period",
            ]
            outcome = await apply(url, station, explain_text)
            assert outcome.error is None and len(outcome.applied) == 2
            assert (await make_plan(url, station)).empty

    asyncio.run(run())


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _serve_world(tmp: Path, published: int) -> tuple[subprocess.Popen[bytes], list[str]]:
    text = (ROOT / "examples" / "gsm-site.toml").read_text()
    text = re.sub(r'(listen|smtp|pop3|api) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    text = text.replace('publish = { "10001" = 20001 }', f'publish = {{ "10001" = {published} }}')
    (tmp / "site.toml").write_text(text)
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(tmp / "site.toml"), "--state",
         str(tmp / "state")],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    assert proc.stdout is not None
    lines: list[str] = []
    pending = b""
    while not any(x.startswith("logger com line joined") for x in lines):
        ready, _, _ = select.select([proc.stdout], [], [], 30)
        chunk = os.read(proc.stdout.fileno(), 4096) if ready else b""
        assert chunk, lines
        pending += chunk
        *done, pending = pending.split(b"\n")
        lines += [x.decode().strip() for x in done]
    return proc, lines


def _port(lines: list[str], prefix: str) -> int:
    return int(re.findall(r":(\d+)", next(x for x in lines if x.startswith(prefix)))[0])


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sondalog", "logger", "config", *args],
        capture_output=True, text=True, timeout=180, cwd=cwd, check=False,
    )  # fmt: skip


def test_over_a_gsm_data_call_and_the_gprs_port(tmp_path: Path) -> None:
    published = _free_port()
    proc, lines = _serve_world(tmp_path, published)
    try:
        with socket.create_connection(("127.0.0.1", _port(lines, "logger "))) as cable:
            cable.settimeout(10)
            for command in ("write com device wavecom42", "write com close"):
                cable.sendall(command.encode() + b"\r")
                assert cable.recv(100) == b"OK\r\n"
        (tmp_path / "s.toml").write_text(
            '[channel.3]\nname = "Voda"\n[com]\ndevice = "WAVECOM42"\n'
        )
        call = f"gsm://127.0.0.1:{_port(lines, 'gsm API')}/{MODEM}?from={PHONE}"
        deadline = time.monotonic() + 90
        while True:  # the logger first registers with the network through its modem
            plan = _cli("plan", call, "s.toml", cwd=tmp_path)
            if plan.returncode != 2 or time.monotonic() > deadline:
                break
            time.sleep(2)
        assert plan.returncode == 1, plan.stderr
        assert "channel 3 name: Supply[V] -> Voda" in plan.stdout
        applied = _cli("apply", call, "s.toml", "--yes", cwd=tmp_path)
        assert applied.returncode == 0, applied.stderr
        gprs = _cli("plan", f"tcp://127.0.0.1:{published}", "s.toml", cwd=tmp_path)
        assert gprs.returncode == 0, gprs.stderr
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)
