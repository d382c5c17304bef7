"""``sondalog logger replay TRACE``: a recorded line served back as a device (issue 23).

The matching is the pure :class:`~sondalog.protocol.replay.ReplayDevice`; here it is read
from its file and served by the one runtime over TCP (and ptys), like any core.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.io.clock import RealClock
from sondalog.io.host import DeviceHost
from sondalog.io.pty import PtyLine
from sondalog.io.tcp import TcpServer, serve_tcp
from sondalog.protocol.line_trace import MAX_BYTES, TraceError, parse_trace
from sondalog.protocol.replay import Deviation, ReplayDevice

__all__ = ["Replay", "TraceError", "load_replay", "start_replay"]


def load_replay(path: Path, *, lenient: bool = False) -> ReplayDevice:
    """The replay device of the trace file ``path``; raises :class:`TraceError` (a
    ``ValueError`` naming the file and line) or ``OSError``."""
    size = path.stat().st_size
    if size > 4 * MAX_BYTES:
        raise TraceError(f"{path}: {size} bytes is more than a trace may hold")
    with path.open(encoding="latin-1") as handle:
        chunks = parse_trace(handle, str(path))
    device = ReplayDevice(chunks, lenient=lenient)
    if not device.exchanges:
        raise TraceError(f"{path}: the trace records nothing the host sent")
    return device


@dataclass
class Replay:
    """A served replay: its device (for the deviations), host and servers."""

    device: ReplayDevice
    host: DeviceHost
    servers: list[TcpServer]
    ptys: list[PtyLine] = field(default_factory=list)
    closed_lines: asyncio.Event = field(default_factory=asyncio.Event)

    @property
    def address(self) -> tuple[str, int]:
        return self.servers[0].address

    @property
    def url(self) -> str:
        host, port = self.address
        return f"tcp://{f'[{host}]' if ':' in host else host}:{port}"

    @property
    def deviations(self) -> list[Deviation]:
        return self.device.deviations

    def summary(self) -> str:
        """One line: how much was replayed and how it went."""
        device = self.device
        mode = "lenient" if device.lenient else "strict"
        return (
            f"replay ({mode}): {device.played} exchanges answered from the recording of "
            f"{len(device.exchanges)}, {device.deviation_count} deviations"
        )

    async def close(self) -> None:
        for server in self.servers:
            await server.close()
        for pty in self.ptys:
            pty.close()
        await self.host.stop()


async def start_replay(
    device: ReplayDevice,
    listen: tuple[str, int],
    *,
    ptys: Sequence[Path] = (),
    on_deviation: Callable[[Deviation], None] | None = None,
) -> Replay:
    """Serve ``device`` on ``listen`` (port 0: a free one) and on each pty of ``ptys``.

    ``on_deviation`` is called for each deviation as it happens (the CLI prints them);
    :attr:`Replay.closed_lines` is set whenever a line closes (``--once``)."""
    host = DeviceHost(device, RealClock())
    replay = Replay(device, host, [])
    device.on_deviation = on_deviation
    device.on_close = lambda line: replay.closed_lines.set()
    try:
        replay.servers.append(await serve_tcp(host, *listen))
        for path in ptys:
            replay.ptys.append(PtyLine(host, path))
        host.start()
    except BaseException:
        await replay.close()
        raise
    return replay
