"""``make demo``: serve a virtual ALA1 logger and show how to talk to it.

Starts a logger over the state directory ``./state/demo`` on ``127.0.0.1:10001`` (the port of
the ALA GPRS modem, §6.11.5.2.4; a free port when that one is taken), prints how to connect,
runs a few sample commands through :mod:`sondalog.client`, then serves until Ctrl-C.
"""

from __future__ import annotations

import asyncio
import signal
import sys
from datetime import datetime
from pathlib import Path

from sondalog.app.logger import Logger, start_logger
from sondalog.client import Ala1Client, Request, Response
from sondalog.io.clock import RealClock
from sondalog.io.tcp import DEFAULT_PORT

STATE_DIR = Path("state/demo")
HOST = "127.0.0.1"

#: (what it shows, the request) for the sample session.
SAMPLES: tuple[tuple[str, Request], ...] = (
    ("protocol version (§6.3.1)", Request("read i version")),
    ("several commands on one line (§7.1)", Request("read i device read i snumber read date")),
    ("a command protected by check (§8.3.1)", Request("read date", check=True)),
    ("an answer with per-line sums (§8.4.2)", Request("read com speed", sum=True)),
    ("an answer with a POSIX cksum line (§8.4.1)", Request("read channel name", crcsum=True)),
    ("a command the logger does not know (§3.3.1)", Request("read weather")),
)


def _show(title: str, response: Response) -> None:
    print(f"  # {title}")
    print(f"  => {response.command}")
    for line in response.raw.decode("latin-1").splitlines():
        print(f"  <= {line}")


async def _start() -> Logger:
    for port in (DEFAULT_PORT, 0):
        try:
            return await start_logger(STATE_DIR, RealClock(), (HOST, port))
        except OSError:
            if port == 0:
                raise
            print(f"port {DEFAULT_PORT} is busy; picking a free port", file=sys.stderr)
    raise AssertionError("unreachable")


async def main() -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    logger = await _start()
    host, port = logger.servers[0].address
    url = f"tcp://{host}:{port}"
    identity = logger.identity
    print(f"sondalog demo: a virtual ALA1 logger, protocol {identity.version.value}, ", end="")
    print(f"serial number {identity.serial_number}, state in {STATE_DIR}/")
    print(f"listening on {host}:{port}\n")
    print("Talk to it from another terminal:")
    print(f"  .venv/bin/sondalog term {url}")
    print(f"  telnet {host} {port}    (or: nc {host} {port}), then type: read i version\n")

    print("A sample session through sondalog.client:")
    async with await Ala1Client.connect(url) as client:
        now = datetime.now().strftime("%Y%m%d%H%M%S")
        _show(
            "set the module clock to this computer's time (§6.2)",
            await client.command(f"write date {now}"),
        )
        for title, request in SAMPLES:
            (response,) = await client.pipeline([request])
            _show(title, response)

    print("\nServing until Ctrl-C.")
    sys.stdout.flush()
    try:
        await stop.wait()
    finally:
        await logger.close()
    print("stopped.")


if __name__ == "__main__":
    asyncio.run(main())
