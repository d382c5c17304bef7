"""The client's wait for pipelined answers (``Ala1Client.read_counted``,
``client/answer_wait.py``, issue 24) against a real TCP peer: a logger that answers each
line as it comes, its answers cut anywhere, with never more than ``BATCH`` lines unanswered
(the window); a peer that stalls, refuses a line, talks on past the answers, goes silent or
hangs up. The answers come back whole, every failure ends (``IncompleteAnswer``,
``NoAnswer``, ``ConnectionLost``), and the reader is woken once, not for each piece."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import time
from collections.abc import AsyncIterator, Sequence

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.ala1 import Version
from sondalog.app.virtual import VirtualLogger
from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ConnectionLost, IncompleteAnswer, NoAnswer
from sondalog.client.answer_wait import CountedWait
from sondalog.client.station_read import (
    BATCH as WINDOW,
)
from sondalog.client.station_read import (
    IDENTIFY,
    Line,
    Part,
    _exchange,
    exchange,
    read_plan,
    sending,
)
from sondalog.client.station_schema import BY_PATTERN

PLAN = read_plan("2.10")
LINES = PLAN.lines[:WINDOW]  # sent at once
BATCH = sending(LINES, "")
assert not BATCH.pieces


def _logger() -> VirtualLogger:
    logger = VirtualLogger(version=Version.V2_10)
    logger.command("write channel 1 name/a,b OK/")
    logger.command("write channel 2 name/ERROR/")
    return logger


ANSWERS = _logger().send(BATCH.payload)

#: What the peer does once the request is in: pieces of bytes, each after a pause (s);
#: ``None``: hang up.
Script = Sequence[tuple[float, bytes | None]]


@contextlib.asynccontextmanager
async def peer(script: Script, expect: bytes = BATCH.payload) -> AsyncIterator[str]:
    """A TCP peer that reads the request (``expect``'s count of CRs), then plays ``script``;
    then it answers every further request of one batch with :data:`ANSWERS` at once."""

    async def request(reader: asyncio.StreamReader, payload: bytes) -> None:
        for _ in range(payload.count(b"\r")):
            await reader.readuntil(b"\r")

    async def play(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        with contextlib.suppress(ConnectionError, asyncio.IncompleteReadError):
            await request(reader, expect)
            for pause, data in script:
                await asyncio.sleep(pause)
                if data is None:
                    writer.close()
                    return
                writer.write(data)
                await writer.drain()
            while True:
                await request(reader, BATCH.payload)
                writer.write(ANSWERS)

    server = await asyncio.start_server(play, "127.0.0.1", 0)
    async with server:
        yield f"tcp://127.0.0.1:{server.sockets[0].getsockname()[1]}"


async def _read(url: str, timeout: float = 5.0, gather: float = 0.0) -> bytes:
    async with await Ala1Client.connect(url, timeout=timeout) as client:
        args = (BATCH.payload, BATCH.expected, BATCH.most, BATCH.answered)
        return await asyncio.wait_for(client.read_counted(*args, gather=gather), 30)


def _cut(data: bytes, cuts: list[int]) -> list[bytes]:
    at = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in itertools.pairwise(at) if b > a]


@settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    cuts=st.lists(st.integers(0, len(ANSWERS)), max_size=30),
    pauses=st.lists(st.sampled_from([0.0, 0.0, 0.001, 0.02]), min_size=31, max_size=31),
)
def test_answers_cut_anywhere_come_back_whole(cuts: list[int], pauses: list[float]) -> None:
    """A logger's answers in any pieces, with pauses between them shorter than the timeout
    (which runs from the last byte): exactly the answers, and the settings in them."""
    pieces = _cut(ANSWERS, cuts)
    script = [(pauses[i % len(pauses)], piece) for i, piece in enumerate(pieces)]

    async def run() -> bytes:
        async with peer(script) as url:
            return await _read(url, timeout=0.5)

    assert asyncio.run(run()) == ANSWERS


WHOLE = PLAN.identified  # the collector's read: 81 lines, in a window of BATCH
LOGGER = _logger()
PER_LINE = [LOGGER.send(f"{line.text}\r".encode("latin-1")) for line in WHOLE.lines]


@contextlib.asynccontextmanager
async def logger_peer(cuts: list[int], pauses: list[float], ahead: list[int]) -> AsyncIterator[str]:
    """A logger as a TCP peer: it answers each line once it has come, in order, line i's
    answer cut at ``cuts[i]`` with ``pauses`` before the pieces; ``ahead`` gets, at each
    line received, how many received lines were not answered yet."""

    async def play(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        came: asyncio.Queue[int] = asyncio.Queue()
        received = answered = 0

        async def receive() -> None:
            nonlocal received
            while received < len(PER_LINE):
                await reader.readuntil(b"\r")
                received += 1
                ahead.append(received - answered)
                came.put_nowait(received - 1)

        task = asyncio.create_task(receive())
        with contextlib.suppress(ConnectionError, asyncio.IncompleteReadError):
            for _ in PER_LINE:
                index = await came.get()
                answer = PER_LINE[index]
                for n, piece in enumerate(_cut(answer, [cuts[index % len(cuts)]])):
                    await asyncio.sleep(pauses[(index + n) % len(pauses)])
                    writer.write(piece)
                    await writer.drain()
                answered += 1
            await task
            await reader.read()
        task.cancel()

    server = await asyncio.start_server(play, "127.0.0.1", 0)
    async with server:
        yield f"tcp://127.0.0.1:{server.sockets[0].getsockname()[1]}"


@settings(max_examples=15, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    cuts=st.lists(st.integers(0, 400), min_size=1, max_size=81),
    pauses=st.lists(st.sampled_from([0.0, 0.0, 0.0, 0.002]), min_size=1, max_size=9),
)
def test_the_window_keeps_at_most_batch_lines_unanswered(
    cuts: list[int], pauses: list[float]
) -> None:
    """The collector's whole read in one flow: the lines go out as their answers come in,
    never more than ``BATCH`` unanswered at the logger, and the answers are whole."""
    ahead: list[int] = []

    async def run() -> bytes:
        async with (
            logger_peer(cuts, pauses, ahead) as url,
            await Ala1Client.connect(url, timeout=5) as client,
        ):
            return await asyncio.wait_for(_exchange(client, WHOLE), 30)

    raw = asyncio.run(run())
    assert raw == b"".join(PER_LINE)
    assert len(ahead) == len(WHOLE.lines) and max(ahead) <= WINDOW
    assert WHOLE.lines[0] == IDENTIFY
    values = PLAN.values(raw[len(PER_LINE[0]) :])
    assert values["channel 1 name"] == "a,b OK" and values["channel 2 name"] == "ERROR"


def test_a_stall_longer_than_the_timeout_ends_the_read_with_what_came() -> None:
    half = ANSWERS[: len(ANSWERS) // 2]

    async def run() -> None:
        async with peer([(0, half), (3.0, ANSWERS[len(half) :])]) as url:
            start = time.monotonic()
            with pytest.raises(IncompleteAnswer, match="stopped short") as caught:
                await _read(url, timeout=0.3)
            assert caught.value.raw == half
            assert time.monotonic() - start < 2.5

    asyncio.run(run())


def test_a_slow_answer_is_never_cut_while_bytes_keep_coming() -> None:
    """Pieces 0.15 s apart for over a second, timeout 0.4 s: the timeout runs from the
    last byte, not from the request."""
    pieces = _cut(ANSWERS, list(range(0, len(ANSWERS), len(ANSWERS) // 8)))

    async def run() -> bytes:
        async with peer([(0.15, piece) for piece in pieces]) as url:
            return await _read(url, timeout=0.4)

    assert asyncio.run(run()) == ANSWERS


def test_silence_is_no_answer_and_a_hang_up_is_a_lost_connection() -> None:
    async def run() -> None:
        async with peer([]) as url:
            with pytest.raises(NoAnswer):
                await _read(url, timeout=0.2)
        for gather in (0.0, 0.05):  # a hang-up while the reading is paused: seen after it
            async with peer([(0, ANSWERS[:100]), (0.01, None)]) as url:
                with pytest.raises(ConnectionLost):
                    await _read(url, timeout=5, gather=gather)
        async with peer([(0, ANSWERS[:100])]) as url:  # silent while paused: the timeout
            with pytest.raises(IncompleteAnswer, match="stopped short"):
                await _read(url, timeout=0.2, gather=0.05)

    asyncio.run(run())


def test_a_peer_that_talks_on_is_bounded() -> None:
    """Bytes without line ends past what the answers can be: left at once, not waited on."""
    noise = b"x" * 1024

    async def run() -> None:
        script = [(0.0005, noise)] * (BATCH.most // len(noise) + 3)
        async with peer(script) as url:
            with pytest.raises(IncompleteAnswer, match="more than the answers can be"):
                await _read(url, timeout=5)

    asyncio.run(run())


def test_bytes_after_the_answers_are_not_the_next_reads() -> None:
    """The answers, then a stray line: the read ends at its line count; the stray line is
    dropped before the next read, whose answers are its own. A stray line in the same
    piece as the answers is returned with them (the caller's parse refuses it)."""

    async def run() -> None:
        script = [(0, ANSWERS), (0.05, b"stray\r\n")]
        args = (BATCH.expected, BATCH.most, BATCH.answered)
        async with peer(script) as url, await Ala1Client.connect(url, timeout=5) as client:
            assert await client.read_counted(BATCH.payload, *args) == ANSWERS
            await asyncio.sleep(0.2)  # the stray line is in
            assert await client.read_counted(BATCH.payload, *args) == ANSWERS
        async with peer([(0, ANSWERS + b"stray\r\n")]) as url:
            assert await _read(url) == ANSWERS + b"stray\r\n"

    asyncio.run(run())


def test_a_refusal_whose_answers_follow_in_pieces_ends_the_read_at_once() -> None:
    """A refused line answers with its echo and ERROR: fewer lines than counted. The read
    ends as soon as the lines after it are in, however they are cut."""
    channel = BY_PATTERN["channel {ch} name"]
    lines = [
        Line("read i name", (Part(BY_PATTERN["i name"], ("i name",)),)),
        Line("read channel 12 name 11 name", (Part(channel, ("x",)), Part(channel, ("y",)))),
        Line("read channel 1 name 2 name", (Part(channel, ("a",)), Part(channel, ("b",)))),
    ]
    answers = b"\r\nOK\r\nread channel 12 name 11 name\r\nERROR\r\nSupply[V]\r\nSupply[V]\r\nOK\r\n"
    expect = sending(lines, "").payload
    at = answers.index(b"ERROR") + 7

    async def run() -> bytes:
        pieces = [answers[:at], answers[at : at + 5], answers[at + 5 : -2], answers[-2:]]
        script = [(0.02, piece) for piece in pieces]
        async with peer(script, expect) as url, await Ala1Client.connect(url, timeout=60) as c:
            start = time.monotonic()
            raw = await asyncio.wait_for(exchange(c, lines), 20)
            assert time.monotonic() - start < 5
            return raw

    assert asyncio.run(run()) == answers


class Recorder:
    """What a wait does with its line, noted: written bytes, reading paused or not."""

    def __init__(self) -> None:
        self.written: list[bytes] = []
        self.reading = True

    def write(self, data: bytes) -> None:
        self.written.append(data)

    def pause_reading(self) -> None:
        assert self.reading
        self.reading = False

    def resume_reading(self) -> None:
        assert not self.reading
        self.reading = True


def test_the_reader_is_woken_once_for_all_the_pieces() -> None:
    """The wait resolves only when the counted line ends are in, whatever the pieces."""

    async def run() -> None:
        buffer = bytearray()
        wait = CountedWait(
            asyncio.get_running_loop(),
            buffer,
            lines=BATCH.expected,
            most=BATCH.most,
            stop=b"ERROR\r\n",
            timeout=5,
        )
        plain = VirtualLogger(version=Version.V2_10).send(BATCH.payload)  # no "ERROR" in it
        pieces = _cut(plain, list(range(0, len(plain), 37)))
        for piece in pieces[:-1]:
            buffer += piece
            wait.set_result(True)  # as the stream does for every piece
            assert not wait.done()
        buffer += pieces[-1]
        wait.set_result(True)
        assert wait.done() and wait.result() is True
        assert wait._timer is None  # its timer let go

        # a window's next lines go out from the stream's callback, no wake for them
        buffer.clear()
        line = Recorder()
        written = line.written
        pieces = [(9, 4, b"third\r"), (3, 1, b"second\r")]  # last first
        loop = asyncio.get_running_loop()
        wait = CountedWait(
            loop, buffer, lines=12, most=999, stop=b"ERROR\r\n", timeout=5, pieces=pieces,
            line=line,
        )  # fmt: skip
        steps = [
            (b"a\r\nb", []),
            (b"\r\nOK\r\n", [b"second\r"]),
            (b"c\r\n" * 6, [b"second\r", b"third\r"]),
        ]
        for piece, sent in steps:
            buffer += piece
            wait.set_result(True)
            assert written == sent and not wait.done()
        assert pieces == []
        wait.cancel()

        closed = CountedWait(asyncio.get_running_loop(), bytearray(b"OK"), lines=9, most=99,
                             stop=b"ERROR\r\n", timeout=5, seen=2)  # fmt: skip
        closed.set_result(True)  # woken with no new bytes: the line closed
        assert closed.result() is True

    asyncio.run(run())


def test_gathering_pauses_the_line_and_always_reads_it_again() -> None:
    """With ``gather`` a piece that does not end the wait stops the line's reading for that
    long; it is read again then, and at every end (answers in, timeout, cancel)."""

    async def run() -> None:
        loop = asyncio.get_running_loop()
        for end in ("answers", "timeout", "cancel"):
            buffer, line = bytearray(), Recorder()
            wait = CountedWait(loop, buffer, lines=3, most=999, stop=b"ERROR\r\n",
                               timeout=0.2, line=line, gather=0.05)  # fmt: skip
            buffer += b"a\r\n"
            wait.set_result(True)
            assert not line.reading and not wait.done()
            await asyncio.sleep(0.08)
            assert line.reading  # read again after gather
            buffer += b"b\r\n"
            wait.set_result(True)
            assert not line.reading
            if end == "answers":
                buffer += b"OK\r\n"
                wait.set_result(True)
                assert wait.result() is True
            elif end == "timeout":
                assert await wait is False
            else:
                wait.cancel()
            assert line.reading, end

    asyncio.run(run())


def test_gathered_answers_over_tcp_come_back_whole_and_the_line_works_after() -> None:
    """A real logger over TCP: the read with gathering, then the line's ordinary commands."""

    async def run() -> None:
        async with (
            logger_peer([0], [0.0], []) as url,
            await Ala1Client.connect(url, timeout=5) as client,
        ):
            raw = await asyncio.wait_for(
                client.read_counted(
                    WHOLE.payload, WHOLE.expected, WHOLE.most, WHOLE.answered,
                    more=WHOLE.pieces, gather=0.01,
                ),
                30,
            )  # fmt: skip
            assert raw == b"".join(PER_LINE)
            transport = client._require_stream().transport
            assert transport is not None and transport.is_reading()

    asyncio.run(run())
