"""A served site with its control API, in the test's event loop, and an HTTP client for it.

The site is the real thing: :func:`sondalog.app.site.load_site` reads a site file,
:func:`sondalog.app.serve.start_site` serves it on TCP, :func:`start_control` serves the
control API on a real socket. The clock is the control API's, paused at :data:`START`: time
moves only when a test steps it (over the API).
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sondalog.app.control_api import ControlServer, start_control
from sondalog.app.serve import RunningSite, start_site
from sondalog.app.site import load_site
from sondalog.client import Client
from sondalog.io.clock_control import ControlledClock

#: 2023-11-14 22:13:20 UTC: where the site's clock starts.
START = 1_700_000_000.0

SITE = """
[logger]
seed = 3
supply = { model = "constant", value = 12.0 }

[[logger.analog]]
address = 16
signal = { model = "constant", value = 1.0 }

[[logger.ds18b20]]
pin = 4
signal = { model = "constant", value = 21.5 }

[[logger.pulses]]
timer = true
rate = 2.0

[logger.serve]
listen = "127.0.0.1:0"
"""


async def http(
    port: int,
    method: str,
    path: str,
    body: object = None,
    *,
    raw: bytes | None = None,
    headers: dict[str, str] | None = None,
) -> tuple[int, Any]:
    """One request on its own connection: (status, the JSON answer)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    data = raw if raw is not None else b"" if body is None else json.dumps(body).encode()
    head = f"{method} {path} HTTP/1.1\r\nHost: test\r\nContent-Length: {len(data)}\r\n"
    head += "Content-Type: application/json\r\nConnection: close\r\n"
    head += "".join(f"{k}: {v}\r\n" for k, v in (headers or {}).items())
    writer.write(head.encode() + b"\r\n" + data)
    answer = await reader.read()
    writer.close()
    top, _, payload = answer.partition(b"\r\n\r\n")
    status = int(top.split()[1])
    return status, json.loads(payload) if payload else None


@dataclass
class Site:
    running: RunningSite
    control: ControlServer
    clock: ControlledClock

    @property
    def port(self) -> int:
        return self.control.address[1]

    async def get(self, path: str) -> Any:
        status, answer = await http(self.port, "GET", path)
        assert status == 200, answer
        return answer

    async def post(self, path: str, body: object = None, status: int = 200) -> Any:
        got, answer = await http(self.port, "POST", path, body)
        assert got == status, answer
        return answer

    def logger_url(self) -> str:
        assert self.running.logger is not None
        host, port = self.running.logger.servers[0].address
        return f"tcp://{host}:{port}"

    async def ask(self, line: str) -> str:
        """One command line on a new connection, in a worker thread (the blocking client)."""
        return await asyncio.to_thread(_ask, self.logger_url(), line)


def _ask(url: str, line: str) -> str:
    with Client(url, timeout=5) as client:
        return "\n".join(client.command(line).lines)


@asynccontextmanager
async def served(tmp_path: Path, text: str = SITE, **control: Any) -> AsyncIterator[Site]:
    """The site of ``text`` served with its control API (the clock paused at START)."""
    path = tmp_path / "site.toml"
    path.write_text(text)
    plan = load_site(path)
    clock = ControlledClock(1.0, start=START, paused=True)
    running = await start_site(plan, tmp_path / "state", clock)
    try:
        server = await start_control(running, clock, "127.0.0.1", 0, **control)
        try:
            yield Site(running, server, clock)
        finally:
            await server.stop()
    finally:
        await running.close()
