"""The servers sondalog is compared with, each run as its own process by the benchmarks.

``python benchmarks/peers.py floor [--port P] [--uvloop]``: the "floor", an asyncio server
that answers every CR-terminated line with ``2.10\\r\\nOK\\r\\n`` (what ``read i version``
answers) and does nothing else: what any asyncio server pays per request here.

``python benchmarks/peers.py pymodbus --port P``: a pymodbus 3.x asyncio TCP server
(``StartAsyncTcpServer``) holding 100 holding registers (values 100..199 from address 0),
answering every unit id.

Both print ``listening on HOST:PORT`` once they accept connections (pymodbus: just before
it starts listening; the caller waits until a connection is accepted).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
from typing import cast

ANSWER = b"2.10\r\nOK\r\n"


class _Floor(asyncio.Protocol):
    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # uvloop's transports are not subclasses of asyncio.Transport: no isinstance check
        self._transport = cast(asyncio.Transport, transport)

    def data_received(self, data: bytes) -> None:
        lines = data.count(b"\r")  # counts across chunk borders too: one answer per CR
        if lines:
            self._transport.write(ANSWER * lines)


async def serve_floor(host: str, port: int) -> None:
    loop = asyncio.get_running_loop()
    server = await loop.create_server(_Floor, host, port)
    bound = server.sockets[0].getsockname()
    print(f"listening on {bound[0]}:{bound[1]}", flush=True)
    await server.serve_forever()


async def serve_pymodbus(host: str, port: int) -> None:
    # 3.x moved these around: ModbusSlaveContext became ModbusDeviceContext (3.10), the
    # server context's first argument was `slaves=` and is now `devices=` (so pass it by
    # position); ModbusSequentialDataBlock(1, ...) serves register address 0 in all of them.
    from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext
    from pymodbus.server import StartAsyncTcpServer

    try:
        from pymodbus.datastore import ModbusDeviceContext as Context
    except ImportError:  # pymodbus < 3.10
        from pymodbus.datastore import (  # type: ignore[attr-defined,no-redef]
            ModbusSlaveContext as Context,
        )

    logging.disable(logging.WARNING)  # 3.16 warns that the datastore classes are deprecated
    block = ModbusSequentialDataBlock(1, list(range(100, 200)))
    context = ModbusServerContext(Context(hr=block), True)
    print(f"listening on {host}:{port}", flush=True)
    await StartAsyncTcpServer(context, address=(host, port))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("server", choices=["floor", "pymodbus"])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=0)
    parser.add_argument("--uvloop", action="store_true", help="run on uvloop")
    args = parser.parse_args()
    if args.uvloop:
        import uvloop

        asyncio.set_event_loop_policy(uvloop.EventLoopPolicy())
    serve = serve_floor if args.server == "floor" else serve_pymodbus
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(serve(args.host, args.port))


if __name__ == "__main__":
    main()
