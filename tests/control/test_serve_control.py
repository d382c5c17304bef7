"""``sondalog serve SITE --control HOST:PORT`` as a user runs it, and the controlled clock."""

from __future__ import annotations

import asyncio
import json
import os
import select
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

from control_site import SITE

from sondalog.io.clock_control import ControlledClock


def _serve(
    tmp_path: Path, *args: str, env: dict[str, str] | None = None
) -> subprocess.Popen[bytes]:
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sondalog",
            "serve",
            str(site),
            "--state",
            str(tmp_path / "s"),
            *args,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env={**os.environ, **(env or {})},
    )


def _line(proc: subprocess.Popen[bytes]) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 20)
    assert ready, "serve printed nothing"
    return proc.stdout.readline().decode().strip()


def _call(url: str, body: object = None) -> object:
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(url, data, method="GET" if data is None else "POST")
    with urllib.request.urlopen(request, timeout=10) as response:
        return json.loads(response.read())


def test_serve_with_control_steps_a_paused_site(tmp_path: Path) -> None:
    proc = _serve(tmp_path, "--control", "127.0.0.1:0")
    try:
        logger, control = _line(proc), _line(proc)
        assert logger.startswith("logger 000001 listening on 127.0.0.1:")
        assert control.startswith("control API on http://127.0.0.1:")
        api = control.rsplit(" ", 1)[1]
        assert _call(api + "/health") == {"ok": True, "devices": 1}
        stopped = _call(api + "/time/pause", {})
        assert isinstance(stopped, dict) and stopped["paused"]
        stepped = _call(api + "/time/step", {"seconds": 86400})
        assert isinstance(stepped, dict) and stepped["now"] == stopped["now"] + 86400
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0


def test_control_beyond_loopback_needs_allow_remote_and_a_token(tmp_path: Path) -> None:
    proc = _serve(tmp_path, "--control", "0.0.0.0:0")
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2 and b"--allow-remote" in err
    proc = _serve(tmp_path, "--control", "0.0.0.0:0", "--allow-remote")
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2 and b"SONDALOG_CONTROL_TOKEN" in err
    proc = _serve(tmp_path, "--control", "127.0.0.1:0", env={"SONDALOG_CONTROL_TOKEN": "short"})
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 2 and b"16 to 256" in err


def test_a_step_wakes_a_sleeper_at_once_and_pause_holds_it() -> None:
    """Liveness of the controlled clock: a sleeper wakes when a step reaches its deadline,
    never while the clock is paused short of it."""

    async def main() -> None:
        clock = ControlledClock(1.0, start=1000.0, paused=True)
        woke: list[float] = []

        async def sleeper(deadline: float) -> None:
            await clock.sleep_until(deadline)
            woke.append(clock.now())

        task = asyncio.ensure_future(sleeper(1060.0))
        await asyncio.sleep(0.05)
        assert woke == []
        clock.step(59)
        await asyncio.sleep(0.01)
        assert woke == []  # one second short
        clock.step(1)
        await asyncio.wait_for(task, 1)
        assert woke == [1060.0]
        # running at 1000x, a minute of clock time is 60 ms of real time
        clock.set_rate(1000)
        clock.resume()
        await asyncio.wait_for(clock.sleep_until(clock.now() + 60), 2)

    asyncio.run(main())
