"""``python -m sondalog.demo`` as a subprocess for the tests: its output read line by line."""

from __future__ import annotations

import queue
import re
import subprocess
import sys
import threading
from pathlib import Path
from types import TracebackType

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
