"""Virtual loggers served over TCP in the test's own event loop, and reading every answer of
their parameter tree (the round-trip tests compare them)."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from sondalog.ala1 import Version
from sondalog.ala1.params import storage_keys
from sondalog.app.explain import explain
from sondalog.app.logger import Logger, start_logger
from sondalog.client import Ala1Client
from sondalog.io.clock import RealClock


def explain_text(line: str, version: str) -> str:
    return explain(line, version).render()


@dataclass
class Served:
    url: str
    logger: Logger


@contextlib.asynccontextmanager
async def served(
    state: Path, version: str = "2.10", serial: str = "000001", ptys: Sequence[Path] = ()
) -> AsyncIterator[Served]:
    logger = await start_logger(
        state, RealClock(), ("127.0.0.1", 0), Version(version), serial, ptys=ptys
    )
    host, port = logger.servers[0].address
    try:
        yield Served(f"tcp://{host}:{port}", logger)
    finally:
        await logger.close()


async def ask(url: str, commands: Sequence[str], iaddress: str = "") -> list[str]:
    """Run each command; returns 'OK' or 'ERROR' per command."""
    prefix = f"iaddress|{iaddress}| " if iaddress else ""
    async with await Ala1Client.connect(url) as client:
        answers = await client.pipeline([prefix + c for c in commands])
    return [a.status.value for a in answers]


async def every_read(url: str, version: str, iaddress: str = "") -> dict[str, tuple[str, ...]]:
    """The answer to ``read`` of every stored parameter of the tree (both inputs of a
    two-input one), and of the identity."""
    commands = ["read i version", "read i snumber", "read i device", "read i program"]
    for key, info in storage_keys(Version(version)).items():
        if "#" in key or "R" not in info.leaf.access:
            continue
        commands.append(f"read {key}{' all' if info.leaf.dual else ''}")
    prefix = f"iaddress|{iaddress}| " if iaddress else ""
    out: dict[str, tuple[str, ...]] = {}
    async with await Ala1Client.connect(url) as client:
        for start in range(0, len(commands), 100):
            chunk = commands[start : start + 100]
            answers = await client.pipeline([prefix + c for c in chunk])
            for command, answer in zip(chunk, answers, strict=True):
                out[command] = (answer.status.value, *answer.lines)
    return out
