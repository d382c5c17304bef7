"""plan and apply over the other lines the client knows (issue 22): a serial line (the pty of
a served logger), a GSM data call (gsm://) and the GPRS port of the served GSM network."""

from __future__ import annotations

import asyncio
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from station_helpers import ask, explain_text, free_port, port_of, serve_gsm_world, served

from sondalog.client.station_apply import apply, make_plan
from sondalog.client.station_file import read_station
from sondalog.config import loads

MODEM, PHONE = "+420600000001", "+420700000001"


def test_over_a_serial_line(tmp_path: Path) -> None:
    """com speed is written last on a serial line (the line changes speed with it), after
    the i address; then the logger answers at the new speed, with the address."""
    station = read_station(
        loads(
            '[identity]\naddress = "A1"\n[channel.2]\nname = "Voda"\n'
            'sampling_period = "000100"\n[com]\nspeed = 115200\n'
        )
    )

    async def run() -> None:
        link = tmp_path / "ala1"
        async with served(tmp_path / "s", "1.16", ptys=[link]) as lg:
            slow, fast = f"serial://{link}?baud=9600", f"serial://{link}?baud=115200"
            outcome = await apply(slow, station, explain_text)
            assert outcome.error is None, outcome.error
            assert [line.split(":")[0] for line in outcome.applied] == [
                "channel 2 name",
                "channel 2 sampling period",
                "i address",
                "com speed",
            ]
            assert outcome.warnings == ["com speed is now 115200: reconnect at that rate"]
            assert (await make_plan(fast, station)).empty
            assert await ask(lg.url, ["read com speed"], iaddress="A1") == ["OK"]

    asyncio.run(run())


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sondalog", "logger", "config", *args],
        capture_output=True, text=True, timeout=180, cwd=cwd, check=False,
    )  # fmt: skip


# Three exchanges paced at the modem's line speed (about 11 s each alone) and two waits of up
# to 90 s each: its own budget, so a slow run ends in an assertion that shows the CLI's last
# answer instead of pytest's bare timeout (it overran the default 120 s once, in a full run).
@pytest.mark.timeout(300)
def test_over_a_gsm_data_call_and_the_gprs_port(tmp_path: Path) -> None:
    published = free_port()
    proc, lines = serve_gsm_world(tmp_path, published)
    try:
        with socket.create_connection(("127.0.0.1", port_of(lines, "logger "))) as cable:
            cable.settimeout(10)
            for command in ("write com device wavecom42", "write com close"):
                cable.sendall(command.encode() + b"\r")
                assert cable.recv(100) == b"OK\r\n"
        (tmp_path / "s.toml").write_text(
            '[channel.3]\nname = "Voda"\n[com]\ndevice = "WAVECOM42"\n'
        )
        call = f"gsm://127.0.0.1:{port_of(lines, 'gsm API')}/{MODEM}?from={PHONE}"
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
        deadline = time.monotonic() + 90
        while True:  # after the call the modem goes back on line for GPRS (gsm.md §7)
            gprs = _cli("plan", f"tcp://127.0.0.1:{published}", "s.toml", cwd=tmp_path)
            if gprs.returncode != 2 or time.monotonic() > deadline:
                break
            time.sleep(2)
        assert gprs.returncode == 0, gprs.stderr
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)
