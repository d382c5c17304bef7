"""A noisy line: bit errors at a rate show up as ``crcsum`` errors at that rate (§8.4.1)."""

from __future__ import annotations

import asyncio
import random
from pathlib import Path

from control_site import served

from sondalog.app.control_actions import Noise
from sondalog.app.faults_line import garble
from sondalog.client.ala1_codec import ChecksumError, Request, parse_answer

COMMAND = "read i version read i device read i snumber read channel name"


def _verdict(raw: bytes) -> bool:
    """Whether ``raw`` is a verified crcsum answer to :data:`COMMAND`."""
    lines = raw.splitlines(keepends=True)
    try:
        return parse_answer(Request(COMMAND, crcsum=True), lines) is not None
    except ChecksumError:
        return False


def test_bit_errors_at_a_rate_are_checksum_errors_at_that_rate(tmp_path: Path) -> None:
    async def main() -> None:
        async with served(tmp_path) as site:
            address = site.running.logger.servers[0].address
            reader, writer = await asyncio.open_connection(*address)
            line = Request(COMMAND, crcsum=True).line().encode() + b"\r"

            async def answer(size: int | None = None) -> bytes:
                writer.write(line)
                if size is None:
                    return await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 5)
                return await asyncio.wait_for(reader.readexactly(size), 5)  # flips keep sizes

            clean = await answer()
            assert _verdict(clean)
            rate = 0.004  # per byte
            body = {"kind": "noise", "rate": rate, "mode": "flip", "seed": 7}
            await site.post("/devices/logger/fault", body)
            count = 400
            bad = 0
            for _ in range(count):
                bad += not _verdict(await answer(len(clean)))
            expected = 1 - (1 - rate) ** len(clean)  # some byte of the answer was hit
            spread = 4 * (expected * (1 - expected) / count) ** 0.5
            assert abs(bad / count - expected) < spread, (bad, count, expected)
            await site.post("/devices/logger/clear", {"kind": "noise"})
            for _ in range(20):
                assert _verdict(await answer())
            writer.close()

    asyncio.run(main())


def test_garble_drops_duplicates_and_flips_at_the_rate() -> None:
    data = bytes(range(256)) * 400
    for mode, change in (("drop", -1), ("duplicate", +1)):
        out = garble(data, Noise(0.01, mode=mode), random.Random(1))
        hits = (len(out) - len(data)) * change
        assert 0.01 * len(data) * 0.85 < hits < 0.01 * len(data) * 1.15
    flipped = garble(data, Noise(0.01, mode="flip"), random.Random(1))
    diff = [a ^ b for a, b in zip(data, flipped, strict=True) if a != b]
    assert 0.85 < len(diff) / (0.01 * len(data)) < 1.15
    assert all(bin(d).count("1") == 1 for d in diff)  # one bit each
    assert garble(data, Noise(0.01), random.Random(5)) == garble(
        data, Noise(0.01), random.Random(5)
    )
