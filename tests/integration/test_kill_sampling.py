"""SIGKILL during heavy sampling (issue 3): after a restart over the same state directory the
record is consistent, every row read before the kill is still there, and the counters and
stamps continue."""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

from ala1_served import ServedLogger, exchange

Serve = Callable[..., ServedLogger]
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ROW = re.compile(rb"^\d{14}\.[0-9A-Z],1,(-?\d+\.\d{3},){11}-?\d+\.\d{3}$")


def _ask(sock: object, command: str) -> bytes:
    return exchange(sock, command.encode() + b"\r", b"OK\r\n")  # type: ignore[arg-type]


def _record(sock: object) -> list[bytes]:
    answer = _ask(sock, "read record 100000 from start")
    return answer.split(b"\r\n")[:-2]


def test_kill_during_heavy_sampling_keeps_the_record(serve: Serve, tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(
        "[logger]\n[[logger.analog]]\naddress = 16\n"
        "signal = { model = 'sine', mean = 1.2, amplitude = 1.0, period = 600 }\n"
    )
    served = serve("--site", str(site), "--speed", "2000")
    with served.connect() as sock:
        assert _ask(sock, "write date 20070301000000") == b"OK\r\n"
        assert _ask(sock, "write channel max number 12") == b"OK\r\n"
        for ch in range(1, 13):
            for part in (
                "type 3",
                "address 16",
                "switch output 0",
                "format 0.3",
                "record change 0",
            ):
                assert _ask(sock, f"write channel {ch} {part}") == b"OK\r\n"
        # one line for all twelve, so they share rows (the factory start is in the past)
        periods = " ".join(["000010"] * 12)
        assert _ask(sock, f"write channel sampling period {periods}") == b"OK\r\n"
        time.sleep(1.0)  # about 200 rows a second of wall-clock time
        before = _record(sock)
    assert len(before) > 50
    served.kill()

    again = serve("--site", str(site), "--speed", "2000", state=served.state)
    with again.connect() as sock:
        time.sleep(0.3)
        # one line: the status and the rows of the same instant (sampling goes on)
        lines = _ask(sock, "read record status read record 100000 from start").split(b"\r\n")
        status, after = lines[0].split(b","), lines[1:-2]
    assert after[: len(before)] == before  # nothing read before the kill is lost
    assert len(after) > len(before)  # sampling went on after the restart
    assert all(ROW.match(row) for row in after), [r for r in after if not ROW.match(r)][:3]
    keys = [row.split(b",")[0] for row in after]
    assert keys == sorted(keys) and len(set(keys)) == len(keys)  # stamps and counters go on
    assert int(status[0]) == sum(len(row) + 2 for row in after)
