"""Virtual loggers served over TCP in the test's own event loop, and reading every answer of
their parameter tree (the round-trip tests compare them)."""

from __future__ import annotations

import contextlib
import os
import re
import select
import socket
import subprocess
import sys
from collections.abc import AsyncIterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from sondalog.ala1 import Version
from sondalog.ala1.params import storage_keys
from sondalog.app.explain import explain
from sondalog.app.logger import Logger, start_logger
from sondalog.client import Ala1Client
from sondalog.io.clock import RealClock

ROOT = Path(__file__).resolve().parents[2]
MODEM, PHONE = "+420600000001", "+420700000001"


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


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def serve_gsm_world(tmp: Path, published: int) -> tuple[subprocess.Popen[bytes], list[str]]:
    text = (ROOT / "examples" / "gsm-site.toml").read_text()
    text = re.sub(r'(listen|smtp|pop3|api) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    text = text.replace('publish = { "10001" = 20001 }', f'publish = {{ "10001" = {published} }}')
    (tmp / "site.toml").write_text(text)
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(tmp / "site.toml"), "--state",
         str(tmp / "state")],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    assert proc.stdout is not None
    lines: list[str] = []
    pending = b""
    while not any(x.startswith("logger com line joined") for x in lines):
        ready, _, _ = select.select([proc.stdout], [], [], 30)
        chunk = os.read(proc.stdout.fileno(), 4096) if ready else b""
        assert chunk, lines
        pending += chunk
        *done, pending = pending.split(b"\n")
        lines += [x.decode().strip() for x in done]
    return proc, lines


def port_of(lines: list[str], prefix: str) -> int:
    return int(re.findall(r":(\d+)", next(x for x in lines if x.startswith(prefix)))[0])
