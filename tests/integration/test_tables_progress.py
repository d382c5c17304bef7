"""Progress of ``logger tables push|pull`` over a real paced pty at 9600 baud (issue 16, item
3): every phase has its own report, starting at 0 of a known total and ending at the total, and
the values in between follow blocks taken by the other side, not bytes queued."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from pathlib import Path

from ala1_served import ServedLogger, exchange

from sondalog.client import Ala1Client
from sondalog.client.tables import pull, push

Serve = Callable[..., ServedLogger]
Calls = list[tuple[str, int, int]]


def _tables() -> dict[str, bytes]:
    """Two 1-D tables (§10.2) of about 1.3 kB each."""
    first = "".join(f"{i} {i * 2.5}\n" for i in range(150)).encode()
    second = "".join(f"{i * 10} {1000 - i}\n" for i in range(130)).encode()
    return {"linear": first, "falling": second}


def _by_phase(calls: Calls) -> dict[str, list[tuple[int, int]]]:
    phases: dict[str, list[tuple[int, int]]] = {}
    for phase, done, total in calls:
        phases.setdefault(phase, []).append((done, total))
    return phases


def _blocks(steps: list[int]) -> bool:
    """Whole XMODEM blocks: 1 kB ones, then 128-byte ones for the tail."""
    return steps[:2] == [1024, 2048] and all(step % 128 == 0 for step in steps)


def _check_phase(reports: list[tuple[int, int]], total: int) -> list[int]:
    """Starts at 0 of ``total``, never goes back, ends at ``total``; the values between."""
    assert reports[0] == (0, total)
    assert reports[-1] == (total, total)
    assert all(t == total for _, t in reports)
    done = [d for d, _ in reports]
    assert done == sorted(done)
    return sorted({d for d in done if 0 < d < total})


def test_push_and_pull_report_every_phase_on_a_9600_line(serve: Serve, tmp_path: Path) -> None:
    link = tmp_path / "ala1"
    served = serve("--pty", str(link))
    with served.connect() as sock:
        partition = b"write file record size 983040 write file list size 256 "
        assert exchange(sock, partition + b"write file data size 51200\r", b"OK\r\n") == b"OK\r\n"
    tables = _tables()
    pushed: Calls = []
    pulled: Calls = []

    async def work() -> tuple[tuple[bytes, bytes], dict[str, bytes]]:
        url = f"serial://{link}?baud=9600"
        async with await Ala1Client.connect(url, timeout=5) as client:
            files = await push(client, tables, lambda *call: pushed.append(call))
            got = await pull(client, lambda *call: pulled.append(call))
        return files, got

    (listing, data), got = asyncio.run(work())
    assert got == tables
    assert len(data) == sum(len(body) for body in tables.values()) > 2048

    phases = _by_phase(pushed)
    assert list(phases) == ["upload list", "upload data", "check list", "check data"]
    assert _check_phase(phases["upload list"], len(listing)) == []  # one 128-byte block
    # data: 1 kB blocks, each counted once the logger acknowledged it
    assert _blocks(_check_phase(phases["upload data"], len(data)))
    _check_phase(phases["check list"], len(listing))
    # the read-back, paced at 9600 baud (about 1 s per block), moves block by block
    assert _blocks(_check_phase(phases["check data"], len(data)))

    phases = _by_phase(pulled)
    assert list(phases) == ["download list", "download data"]
    first = phases["download list"]
    assert first[0] == (0, 0)  # the list's size is not known before it arrives ...
    assert first[-1] == (len(listing), len(listing))
    # ... and the data's is, from the list (§10.4)
    assert _blocks(_check_phase(phases["download data"], len(data)))
