"""The collector's TCP contacts on the loop's epoll (:mod:`sondalog.io.tcp_epoll`, issue 24),
against real TCP peers that misbehave, on the standard loop and on uvloop: an answer in slow
pieces, a peer that cuts the answer, a refused connect, a peer that never answers, a request
larger than the socket takes at once; the client raises what it raises through the loop's own
transports (``Ala1Client`` over ``TcpEndpoint``), and no descriptor is left behind."""

from __future__ import annotations

import asyncio
import os
import socket
from collections.abc import Awaitable, Callable
from typing import Any

import pytest

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import ConnectionLost, NoAnswer
from sondalog.client.endpoints import Endpoint, PolledTcpEndpoint, TcpEndpoint, for_contacts
from sondalog.io import tcp_epoll

pytestmark = pytest.mark.skipif(not tcp_epoll.available(), reason="no epoll here")

Handler = Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]


def _loops() -> list[Any]:
    factories: list[Any] = [pytest.param(asyncio.new_event_loop, id="asyncio")]
    try:
        import uvloop

        factories.append(pytest.param(uvloop.new_event_loop, id="uvloop"))
    except ImportError:
        pass
    return factories


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _both(loop_factory: Any, handler: Handler, body: Callable[[Endpoint], Awaitable[Any]]) -> Any:
    """``body`` run with a polled endpoint and with the loop's own, against ``handler``."""

    async def closing(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            await handler(reader, writer)
        finally:
            writer.close()

    async def main() -> Any:
        server = await asyncio.start_server(closing, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        before = _fds()
        try:
            out: list[Any] = []
            for endpoint in (
                PolledTcpEndpoint(TcpEndpoint("127.0.0.1", port)),
                TcpEndpoint("127.0.0.1", port),
            ):
                try:
                    out.append(await body(endpoint))
                except Exception as exc:
                    out.append(f"{type(exc).__name__}")
            await asyncio.sleep(0.25)  # the server's side closes
            assert _fds() <= before + 1  # the loop's epoll: no descriptor a connection
            return out
        finally:
            server.close()

    with asyncio.Runner(loop_factory=loop_factory) as runner:
        return runner.run(main())


async def _ask(endpoint: Endpoint, payload: bytes = b"read i snumber\r") -> Any:
    client = await Ala1Client.connect(endpoint, timeout=0.5)
    try:
        return (await client.pipeline([payload.decode().rstrip("\r")]))[0].lines
    finally:
        await client.close()


@pytest.mark.parametrize("loop_factory", _loops())
def test_a_slow_answer_in_pieces_is_read_whole(loop_factory: Any) -> None:
    async def slow(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readuntil(b"\r")
        for piece in (b"F0", b"0001\r", b"\nO", b"K\r\n"):
            writer.write(piece)
            await writer.drain()
            await asyncio.sleep(0.1)  # each piece well within the timeout of 0.5 s
        await reader.read()

    assert _both(loop_factory, slow, _ask) == [("F00001",), ("F00001",)]


@pytest.mark.parametrize("loop_factory", _loops())
def test_a_cut_answer_a_silent_peer_and_a_refused_connect(loop_factory: Any) -> None:
    async def cut(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readuntil(b"\r")
        writer.write(b"F000")
        await writer.drain()
        writer.close()

    async def silent(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.read()  # reads, never answers, until the client closes

    assert _both(loop_factory, cut, _ask) == [ConnectionLost.__name__] * 2
    assert _both(loop_factory, silent, _ask) == [NoAnswer.__name__] * 2
    free = socket.socket()
    free.bind(("127.0.0.1", 0))
    port = free.getsockname()[1]
    free.close()  # nothing listens there

    async def refused() -> list[str]:
        out = []
        for endpoint in (
            PolledTcpEndpoint(TcpEndpoint("127.0.0.1", port)),
            TcpEndpoint("127.0.0.1", port),
        ):
            with pytest.raises(ConnectionRefusedError) as caught:
                await Ala1Client.connect(endpoint)
            out.append(caught.value.errno)
        return out

    with asyncio.Runner(loop_factory=loop_factory) as runner:
        assert runner.run(refused()) == [111, 111]


@pytest.mark.parametrize("loop_factory", _loops())
def test_a_request_larger_than_the_socket_takes_goes_out_whole(loop_factory: Any) -> None:
    line = b"read i snumber " + b"x" * (4 << 20)  # more than the socket's buffers

    async def late_reader(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await asyncio.sleep(0.2)  # the client's write waits for room meanwhile
        got = await reader.readexactly(len(line) + 1)
        writer.write(f"{len(got)}\r\nOK\r\n".encode())
        await writer.drain()
        await reader.read()

    async def ask_big(endpoint: Endpoint) -> Any:
        return await _ask(endpoint, line + b"\r")

    assert _both(loop_factory, late_reader, ask_big) == [(str(len(line) + 1),)] * 2


def test_names_are_looked_up_once_and_again_after_a_failure() -> None:
    async def main() -> None:
        server = await asyncio.start_server(lambda r, w: w.close(), "localhost", 0)
        port = server.sockets[0].getsockname()[1]
        resolved = tcp_epoll.Resolved("localhost", port)
        transport, _ = await tcp_epoll.open_connection(resolved, asyncio.Protocol)
        transport.close()
        found = resolved._found
        assert found is not None and found[1][1] == port
        server.close()
        await server.wait_closed()
        with pytest.raises(ConnectionRefusedError):
            await tcp_epoll.open_connection(resolved, asyncio.Protocol)
        assert resolved._found is None  # looked up again at the next contact
        literal = tcp_epoll.Resolved("127.0.0.1", port)
        with pytest.raises(ConnectionRefusedError):
            await tcp_epoll.open_connection(literal, asyncio.Protocol)
        assert literal._found == (socket.AF_INET, ("127.0.0.1", port))  # nothing to look up

    asyncio.run(main())
    assert isinstance(for_contacts(TcpEndpoint("h", 1)), PolledTcpEndpoint)
