"""A served logger sends its periodic messages by itself (§6.14, ``com device local``): they
arrive as plain text on a TCP line that has not sent a command, on time at ``--speed``."""

from __future__ import annotations

import time
from collections.abc import Callable
from datetime import datetime

from ala1_served import ServedLogger, exchange, read_until

Serve = Callable[..., ServedLogger]


def test_periodic_message_arrives_on_a_quiet_line(serve: Serve) -> None:
    served = serve("--speed", "60")  # a module minute is a real second
    with served.connect() as setup:
        for command in (
            b"write command 1 value/read date/",
            b"write message 1 start 20000101000000 period 000100",
        ):
            assert exchange(setup, command + b"\r", b"\r\n") == b"OK\r\n"
    # the configuring line is gone; a new line that sends nothing gets the messages
    with served.connect() as quiet:
        started = time.monotonic()
        data = b"".join(read_until(quiet, b"OK\r\n", timeout=10) for _ in range(3))
        elapsed = time.monotonic() - started
    lines = data.decode().split("\r\n")
    assert lines[1::2] == ["OK", "OK", "OK"], data
    # (a message due while no line was attached goes out when one connects: skip the first)
    stamps = [datetime.strptime(s, "%Y%m%d%H%M%S") for s in lines[2:6:2]]
    assert stamps[0].second == 0 and (stamps[1] - stamps[0]).total_seconds() == 60
    assert elapsed < 6.0  # about one real second per module minute
