"""``sondalog term`` over a real paced pty at 9600 baud (issue 16, item 1): an answer that takes
longer than ``--timeout`` is never cut while bytes keep arriving, and an answer whose line dies
mid-way is reported on stderr with exit status 1."""

from __future__ import annotations

import asyncio
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from ala1_served import ServedLogger

from sondalog.client import Ala1Client
from sondalog.client.transfer import upload

Serve = Callable[..., ServedLogger]
TERM = [sys.executable, "-m", "sondalog", "term"]
ROWS = 150  # 150 rows of 23 bytes + OK: about 3.6 s at 9600 baud, longer than --timeout 1


def _rows() -> list[str]:
    """Rows of type 2 (§9), one a minute from 2007-01-01 00:00."""
    return [f"20070101{i // 60:02d}{i % 60:02d}00.0,2,{i:04d}" for i in range(ROWS)]


def _logger_with_record(serve: Serve, tmp_path: Path) -> tuple[ServedLogger, Path]:
    link = tmp_path / "ala1"
    served = serve("--pty", str(link))
    image = "".join(row + "\r\n" for row in _rows()).encode()

    async def fill() -> None:
        async with await Ala1Client.connect(served.url) as client:
            await upload(client, "write special file record xmodem", image)
            status = await client.command("read record status")
            assert status.lines[0].startswith(f"{len(image)},")

    asyncio.run(fill())
    return served, link


def test_a_long_answer_on_a_slow_line_is_not_cut(serve: Serve, tmp_path: Path) -> None:
    _, link = _logger_with_record(serve, tmp_path)
    started = time.monotonic()
    done = subprocess.run(
        [*TERM, f"serial://{link}?baud=9600", "--timeout", "1"],
        input="read record 500 from start\n",
        capture_output=True,
        text=True,
        timeout=60,
    )
    took = time.monotonic() - started
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    assert done.stdout == "".join(row + "\n" for row in _rows()) + "OK\n"
    assert took > 3  # the answer outlasted --timeout several times over


def test_a_line_that_dies_mid_answer_is_reported(serve: Serve, tmp_path: Path) -> None:
    served, link = _logger_with_record(serve, tmp_path)
    script = tmp_path / "script.txt"
    script.write_text("read record 500 from start\nread i version\n")
    with script.open() as stdin:
        term = subprocess.Popen(
            [*TERM, f"serial://{link}?baud=9600", "--timeout", "1"],
            stdin=stdin,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
    # 500 rows take about 40 s at 9600 baud: after 4 s (term's start may take 2 on a loaded
    # machine) a few dozen rows are out and most are still to come
    time.sleep(4)
    served.proc.send_signal(signal.SIGSTOP)  # the line goes silent mid-answer
    try:
        out, err = term.communicate(timeout=30)
    finally:
        served.proc.send_signal(signal.SIGCONT)
    assert term.returncode == 1
    lines = out.splitlines()
    assert 10 < len(lines) < ROWS
    assert lines == _rows()[: len(lines)] or lines[:-1] == _rows()[: len(lines) - 1]
    assert "OK" not in lines
    assert "incomplete answer to 'read record 500 from start'" in err
    assert "no final OK or ERROR; nothing more came for 1 s (--timeout)" in err
