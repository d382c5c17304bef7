"""Run one sans-I/O mail core over an asyncio stream pair (client or server side)."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Protocol


class StreamCore(Protocol):
    """What :func:`pump` needs of a core: h11's shape with the caller's clock."""

    wants_close: bool

    @property
    def deadline(self) -> float | None: ...

    def start(self, now: float) -> None: ...

    def receive_data(self, data: bytes, now: float) -> None: ...

    def data_to_send(self) -> bytes: ...

    def handle_timeout(self, now: float) -> None: ...


async def pump(
    core: StreamCore,
    reader: asyncio.StreamReader,
    writer: asyncio.StreamWriter,
) -> str | None:
    """Feed ``core`` until it wants the connection closed; close it. Returns a transport
    error text (the connection broke) or ``None``. The clock is the loop's monotonic time."""
    loop = asyncio.get_running_loop()
    error: str | None = None
    core.start(loop.time())
    try:
        while True:
            out = core.data_to_send()
            if out:
                writer.write(out)
                await writer.drain()
            if core.wants_close:
                break
            deadline = core.deadline
            wait = None if deadline is None else max(0.0, deadline - loop.time())
            try:
                data = await asyncio.wait_for(reader.read(65536), wait)
            except TimeoutError:
                core.handle_timeout(loop.time())
                continue
            core.receive_data(data, loop.time())
    except OSError as exc:
        error = f"connection broke: {exc}"
    finally:
        writer.close()
        with contextlib.suppress(OSError):
            await writer.wait_closed()
    return error
