"""Bus master for HCTMPS1 modules: the host side of the RS-485 bus (hctmps1.md §2, §4).

:class:`BusMaster` talks to modules through a :class:`BusLink` (a TCP-to-RS-485 gateway such
as ``sondalog bus serve``, a serial port or pty, or an in-process port of a virtual bus):
request/response with a timeout and retries on a bad or missing reply, ``scan`` (broadcast
``HELLO`` until no new module answers), ``poll`` (``REPLY`` grants round-robin) and a typed
helper for every command of §4.

URL forms (:func:`parse_bus_url`): ``tcp://HOST:PORT`` and ``serial:///dev/ttyX?baud=9600``
(also for the symlink of ``bus serve --pty``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterable
from dataclasses import dataclass
from typing import TypeVar

from sondalog.client.bus_commands import BusCommands
from sondalog.client.bus_errors import ForeignPeer, NoReply
from sondalog.client.bus_links import (
    DEFAULT_BAUD,
    BusLink,
    BusUrl,
    open_link,
    parse_bus_url,
)
from sondalog.protocol.hctmps1_frames import (
    BROADCAST,
    Frame,
    FrameDecoder,
    encode_frame,
    is_valid_id,
    slot_time,
)

log = logging.getLogger(__name__)

#: ``progress(round, max_rounds, found)`` after each ``HELLO`` broadcast of :meth:`scan`.
ScanProgress = Callable[[int, int, dict[str, str]], None]

T = TypeVar("T")

DEFAULT_HOST_ID = "PC"
#: Longest frame the master expects, for timeouts (a full LISTSUP reply is about 110 bytes).
LONGEST_FRAME = 128


@dataclass(frozen=True, slots=True)
class DataFrame:
    """A measurement released by ``REPLY``: module, its addressee, the value, when received."""

    module: str
    addressee: str
    value: str
    received: float


def _foreign_text(line: bytes) -> bool:
    return (
        len(line) >= 4
        and all(0x20 <= byte < 0x7F for byte in line)
        and not any(sep in line for sep in (b":", b",", b"|"))
    )


class BusMaster(BusCommands):
    """The host's side of the bus protocol (hctmps1.md §2, §4)."""

    def __init__(
        self,
        link: BusLink,
        host_id: str = DEFAULT_HOST_ID,
        *,
        baud: int = DEFAULT_BAUD,
        timeout: float | None = None,
        retries: int = 2,
    ) -> None:
        if not is_valid_id(host_id):
            raise ValueError(f"bad host ID {host_id!r}: 1 to 8 of A-Z a-z 0-9 _ -")
        self.link = link
        self.host_id = host_id
        self.baud = baud
        frame_time = LONGEST_FRAME * 10 / baud
        self.timeout = timeout if timeout is not None else 0.25 + 2 * frame_time
        self.retries = retries
        #: How long to collect answers to a broadcast: 16 slots, a frame, and slack (§2).
        self.broadcast_window = 16 * slot_time(baud) + frame_time + 0.25
        self._decoder = FrameDecoder()
        self._frames: asyncio.Queue[Frame | None] = asyncio.Queue()
        self._reader: asyncio.Task[None] | None = None
        self._lock = asyncio.Lock()
        self.closed = False
        #: The last bytes received (for telling a foreign peer), and frames from others.
        self.heard = bytearray()
        self.frames_from_others = 0

    @classmethod
    async def open(
        cls,
        url: str | BusUrl,
        host_id: str = DEFAULT_HOST_ID,
        *,
        baud: int | None = None,
        timeout: float | None = None,
        retries: int = 2,
    ) -> BusMaster:
        """Open ``url`` and start a master on it (the baud of a serial URL sets the timing)."""
        where = parse_bus_url(url) if isinstance(url, str) else url
        link = await open_link(where)
        master = cls(link, host_id, baud=baud or where.baud, timeout=timeout, retries=retries)
        master.start()
        return master

    def start(self) -> None:
        if self._reader is None:
            self._reader = asyncio.create_task(self._read_loop(), name="bus master reader")

    async def close(self) -> None:
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reader
        await self.link.close()
        self.closed = True

    async def __aenter__(self) -> BusMaster:
        self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    @property
    def garbage(self) -> int:
        """Bytes received that were not part of a valid frame (noise, collisions)."""
        return self._decoder.rejected

    async def _read_loop(self) -> None:
        while data := await self.link.receive():
            self.heard = (self.heard + data)[-256:]
            for frame in self._decoder.feed(data):
                self.frames_from_others += frame.src != self.host_id
                self._frames.put_nowait(frame)
        self.closed = True
        self._frames.put_nowait(None)

    def _drain(self) -> None:
        while not self._frames.empty():
            if self._frames.get_nowait() is None:
                self._frames.put_nowait(None)
                return

    async def _next_frame(self, deadline: float) -> Frame | None:
        """The next received frame, or None at the deadline (loop time)."""
        loop = asyncio.get_running_loop()
        remaining = deadline - loop.time()
        if remaining <= 0:
            return None
        try:
            frame = await asyncio.wait_for(self._frames.get(), remaining)
        except TimeoutError:
            return None
        if frame is None:
            self._frames.put_nowait(None)
            raise ConnectionError("the bus link is closed")
        return frame

    async def transact(
        self,
        dst: str,
        body: str,
        accept: Callable[[Frame], bool],
        *,
        retries: int | None = None,
        timeout: float | None = None,
    ) -> Frame:
        """Send ``body`` to ``dst`` until a frame ``accept`` likes comes back."""
        request = encode_frame(dst, self.host_id, body)
        attempts = 1 + (self.retries if retries is None else retries)
        wait = self.timeout if timeout is None else timeout
        loop = asyncio.get_running_loop()
        async with self._lock:
            for attempt in range(attempts):
                self._drain()
                await self.link.send(request)
                deadline = loop.time() + wait
                while (frame := await self._next_frame(deadline)) is not None:
                    if accept(frame):
                        return frame
                    log.debug("bus master: ignored %r while waiting for %s", frame, body)
                log.debug("bus master: no reply to %s from %s (attempt %d)", body, dst, attempt + 1)
        raise NoReply(f"no reply from {dst} to {body}")

    async def command(
        self, dst: str, command: str, param: str | None = None, *, retries: int | None = None
    ) -> str:
        """Send ``COMMAND[.PARAM]`` to ``dst``; return the reply's parameter (§4)."""
        body = command if param is None else f"{command}.{param}"
        prefix = f"R{command}."

        def accept(frame: Frame) -> bool:
            return frame.dst == self.host_id and frame.src == dst and frame.body.startswith(prefix)

        frame = await self.transact(dst, body, accept, retries=retries)
        return frame.body[len(prefix) :]

    async def broadcast(self, body: str, window: float | None = None) -> list[Frame]:
        """Send ``body`` to ``*`` and collect every reply to the host during the window (§2)."""
        loop = asyncio.get_running_loop()
        command = body.split(".", 1)[0]
        frames: list[Frame] = []
        async with self._lock:
            self._drain()
            await self.link.send(encode_frame(BROADCAST, self.host_id, body))
            deadline = loop.time() + (self.broadcast_window if window is None else window)
            while (frame := await self._next_frame(deadline)) is not None:
                if frame.dst == self.host_id and frame.body.startswith(f"R{command}."):
                    frames.append(frame)
        return frames

    # -- discovery and polling ---------------------------------------------------------------

    async def scan(
        self,
        *,
        max_rounds: int = 30,
        window: float | None = None,
        progress: ScanProgress | None = None,
    ) -> dict[str, str]:
        """Every module on the bus: ``{id: HELLO text}``.

        Broadcasts ``HELLO`` round after round until a round brings no new module and no
        garbled bytes (a collision or noise may have hidden one), or ``max_rounds``. Raises
        :class:`ForeignPeer` after the first round when the peer answered only with text
        lines that are no frames (``ERROR`` from an ALA1 logger).
        """
        found: dict[str, str] = {}
        for number in range(1, max_rounds + 1):
            garbage = self.garbage
            new = False
            for frame in await self.broadcast("HELLO", window):
                if frame.src not in found:
                    found[frame.src] = frame.body[len("RHELLO.") :]
                    new = True
            if progress is not None:
                progress(number, max_rounds, dict(found))
            if number == 1 and self.frames_from_others == 0 and self.garbage:
                self._refuse_foreign()
            if not new and self.garbage == garbage:
                break
        return dict(sorted(found.items()))

    def _refuse_foreign(self) -> None:
        """Raise :class:`ForeignPeer` if what was heard holds a text line that no HCTMPS1
        frame can become: printable ASCII, at least 4 characters, with none of the frame's
        separators ``:`` ``,`` ``|`` (noise or a collision rarely removes all four of a
        frame's, and rarely leaves 4 printable characters; an ALA1 ``ERROR`` is such a line).
        """
        heard = bytes(self.heard)
        lines = [line.strip() for line in heard.replace(b"\r", b"\n").split(b"\n")]
        if any(_foreign_text(line) for line in lines):
            raise ForeignPeer(
                f"the peer answers, but not with HCTMPS1 frames (:DST,SRC,BODY|CRC): it sent"
                f" {heard[-80:]!r}",
                heard,
            )

    async def reply(self, module: str) -> DataFrame | None:
        """``REPLY``: one queued data frame of ``module``, or None for ``NODATA`` (§4)."""

        def accept(frame: Frame) -> bool:
            if frame.src != module:
                return False
            if frame.body == "RREPLY.NODATA":
                return frame.dst == self.host_id
            return frame.body.startswith("RPV.")

        frame = await self.transact(module, "REPLY", accept)
        if frame.body == "RREPLY.NODATA":
            return None
        return DataFrame(frame.src, frame.dst, frame.body[len("RPV.") :], time.time())

    async def poll(
        self, modules: Iterable[str], *, max_rounds: int | None = None
    ) -> list[DataFrame]:
        """Grant ``REPLY`` round-robin until every module says ``NODATA``; the frames collected.

        A module that does not answer after the retries is dropped from the round.
        """
        active = list(dict.fromkeys(modules))
        frames: list[DataFrame] = []
        rounds = 0
        while active and (max_rounds is None or rounds < max_rounds):
            for module in list(active):
                try:
                    data = await self.reply(module)
                except NoReply:
                    log.warning("bus master: %s does not answer REPLY", module)
                    active.remove(module)
                    continue
                if data is None:
                    active.remove(module)
                else:
                    frames.append(data)
            rounds += 1
        return frames

    async def watch(self, modules: Iterable[str], idle: float = 0.5) -> AsyncIterator[DataFrame]:
        """Grant ``REPLY`` round-robin forever, yielding data frames as they come."""
        targets = list(dict.fromkeys(modules))
        while True:
            got = False
            for module in targets:
                try:
                    data = await self.reply(module)
                except NoReply:
                    continue
                if data is not None:
                    got = True
                    yield data
            if not got:
                await asyncio.sleep(idle)


class BlockingBusMaster:
    """A blocking wrapper around :class:`BusMaster`.

    ``with BlockingBusMaster(url) as bus: text = bus.run(lambda m: m.hello("T1"))``
    """

    def __init__(
        self, url: str, host_id: str = DEFAULT_HOST_ID, *, timeout: float | None = None
    ) -> None:
        self._runner = asyncio.Runner()
        self.master = self._runner.run(BusMaster.open(url, host_id, timeout=timeout))

    def run(self, call: Callable[[BusMaster], Awaitable[T]]) -> T:
        async def go() -> T:
            return await call(self.master)

        return self._runner.run(go())

    def close(self) -> None:
        self._runner.run(self.master.close())
        self._runner.close()

    def __enter__(self) -> BlockingBusMaster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
