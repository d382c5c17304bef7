"""``python -m sondalog.demo`` as a subprocess for the tests: its output read line by line."""

from __future__ import annotations

import queue
import re
import subprocess
import sys
import threading
import time
from datetime import datetime
from pathlib import Path
from types import TracebackType

from sondalog.ala1.tokens import period_seconds
from sondalog.client import Client

DEMO = [sys.executable, "-m", "sondalog.demo"]


class DemoProcess:
    """The demo in ``cwd`` with stdout and stderr merged; killed on exit if still running."""

    def __init__(self, cwd: Path, *args: str) -> None:
        self.proc = subprocess.Popen(
            [*DEMO, *args], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        self.lines: list[str] = []
        self._queue: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._queue.put(line)
        self._queue.put("")  # the end

    def wait_for(self, wanted: str, timeout: float = 60) -> str:
        """Read lines until one starts with ``wanted``; returns everything read so far."""
        while not self.lines or not self.lines[-1].startswith(wanted):
            try:
                line = self._queue.get(timeout=timeout)
            except queue.Empty:
                line = ""
            assert line, "".join(self.lines)
            self.lines.append(line)
        return "".join(self.lines)

    def url(self, after: str, pattern: str) -> str:
        """The first match of ``pattern`` right after the text ``after`` in the output."""
        match = re.search(re.escape(after) + f"({pattern})", "".join(self.lines))
        assert match, "".join(self.lines)
        return match.group(1)

    def rest(self) -> str:
        """What the demo printed after the lines read (once it has ended)."""
        self._reader.join(timeout=10)
        out = []
        while not self._queue.empty():
            out.append(self._queue.get())
        return "".join(out)

    def __enter__(self) -> DemoProcess:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=10)
        self._reader.join(timeout=10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()


def _stamp(text: str) -> datetime:
    """A module time stamp (``YYYYMMDDhhmmss``, any ``.c`` counter dropped)."""
    return datetime.strptime(text.split(".", 1)[0], "%Y%m%d%H%M%S")


def _schedules(logger: Client) -> list[tuple[datetime, int]]:
    """``(sampling start, period in seconds)`` of each channel of ``logger`` (§6.5.14)."""
    count = int(logger.command("read channel max number").raise_for_error().lines[0])
    schedules = []
    for channel in range(1, count + 1):
        start = logger.command(f"read channel {channel} sampling start").raise_for_error()
        period = logger.command(f"read channel {channel} sampling period").raise_for_error()
        seconds = period_seconds(period.lines[0])
        assert seconds, f"channel {channel} is not sampled every fixed period: {period.lines}"
        schedules.append((_stamp(start.lines[0]), seconds))
    return schedules


def assert_live_rows_carry_values(url: str, timeout: float = 60) -> int:
    """The rows ``url``'s logger samples from now on (live rows), read over its own protocol
    (``read record N from date``, §6.6.4), carry a number on every channel due at their
    instant, until every channel has been due at least once; returns the rows seen.

    Live means at or after the module time (``read date``) of this first contact: the demo
    serves by then. A channel sampled less often than others is left out of the rows
    between its instants (§6.5.14): its field must hold a number in each row at one of them.
    """
    deadline = time.monotonic() + timeout
    with Client(url, timeout=10) as logger:
        since = logger.command("read date").raise_for_error().lines[0]
        schedules = _schedules(logger)
        seen: set[int] = set()
        while True:
            answer = logger.command(f"read record 1000 from date/{since}/").raise_for_error()
            rows = [line.split(",") for line in answer.lines]
            rows = [row for row in rows if row[1] == "1"]  # scheduled samples (§6.6.2)
            for row in rows:
                stamp = _stamp(row[0])
                assert len(row) == 2 + len(schedules), (url, row)
                for channel, (start, period) in enumerate(schedules, start=1):
                    if (stamp - start).total_seconds() % period:
                        continue  # not due at this instant
                    field = row[1 + channel]
                    assert re.fullmatch(r"-?\d+(\.\d+)?", field), (
                        f"{url}: channel {channel} has no value in the live row {row}"
                    )
                    seen.add(channel)
            if len(seen) == len(schedules):
                return len(rows)
            assert time.monotonic() < deadline, (url, since, schedules, rows)
            time.sleep(0.5)
