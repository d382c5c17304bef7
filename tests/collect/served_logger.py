"""Real ``sondalog logger serve`` subprocesses for the host-side tests, and a quick client."""

from __future__ import annotations

import contextlib
import select
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from sondalog.client import Client

SERVE = [sys.executable, "-m", "sondalog", "logger", "serve"]
CLI = [sys.executable, "-m", "sondalog"]
SITE = """[logger]
[[logger.analog]]
address = 16
signal = { model = "sine", mean = 1.2, amplitude = 1.0, period = 600 }
"""


class Served:
    """A served logger on a free loopback port (killed by :func:`serving`)."""

    def __init__(self, state: Path, *extra: str) -> None:
        self.state = state
        log = state.parent / f"{state.name}.log"
        self.proc = subprocess.Popen(
            [*SERVE, "--listen", "127.0.0.1:0", "--state", str(state), *extra],
            stdout=subprocess.PIPE,
            stderr=log.open("ab"),
        )
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], 15)
        line = self.proc.stdout.readline().decode() if ready else ""
        if not line.startswith("listening on "):
            self.stop()
            raise RuntimeError(f"server did not start: {line!r} {log.read_text()}")
        self.port = int(line.rsplit(":", 1)[1])
        self.url = f"tcp://127.0.0.1:{self.port}"

    def ask(self, *commands: str) -> list[str]:
        """Run commands (each must answer OK); returns all their data lines."""
        out: list[str] = []
        with Client(self.url) as client:
            for command in commands:
                answer = client.command(command, timeout=10)
                assert answer.ok, (command, answer)
                out.extend(answer.lines)
        return out

    def record(self) -> list[str]:
        """Every row of the record, oldest first."""
        return self.ask("read record 1000000 from start")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout=5)
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()


@contextlib.contextmanager
def serving(tmp: Path, *extra: str, name: str = "state") -> Iterator[Served]:
    served = Served(tmp / name, *extra)
    try:
        yield served
    finally:
        served.stop()


def sampling_logger(
    tmp: Path, speed: float = 50.0, *extra: str
) -> contextlib.AbstractContextManager[Served]:
    """A logger with a site file: channel 1 supply, channel 2 an analog input."""
    site = tmp / "site.toml"
    site.write_text(SITE)
    return serving(tmp, "--site", str(site), "--speed", str(speed), *extra)


def configure(served: Served, period: str = "000001") -> None:
    """Two channels sampled every ``period``, stamps from 2007-03-01 (names with units)."""
    served.ask(
        "write date 20070301000000",
        "write channel max number 2",
        "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0",
        "write channel 2 name/Level[m]/ write channel 2 format 0.3",
        "write channel 1 record change 0 write channel 2 record change 0",
        f"write channel sampling period {period} {period}",
    )


def download(
    url: str, out: Path, *extra: str, timeout: float = 60
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, "logger", "download", url, "-o", str(out), *extra],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
