"""``make demo``: serve a virtual ALA1 logger and show how to talk to it.

Starts a logger over the state directory ``./state/demo`` on ``127.0.0.1:10001`` (the port of
the ALA GPRS modem, §6.11.5.2.4; a free port when that one is taken, and it says which),
prints how to connect, runs a few sample commands through :mod:`sondalog.client`, then serves
until Ctrl-C. ``--listen HOST:PORT`` picks the address (``make demo ARGS="--listen
127.0.0.1:20001"``); a port given there is used or the demo stops with a message.
"""

from __future__ import annotations

import argparse
import asyncio
import signal
import sys
from datetime import datetime
from pathlib import Path

from sondalog.app.logger import Logger, start_logger
from sondalog.client import Ala1Client, Request, Response
from sondalog.io.address import format_address, parse_listen
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


async def _start(listen: tuple[str, int] | None) -> Logger:
    """Listen on ``listen``, or on 10001 and else on a free port (saying so)."""
    if listen is not None:
        return await start_logger(STATE_DIR, RealClock(), listen)
    try:
        return await start_logger(STATE_DIR, RealClock(), (HOST, DEFAULT_PORT))
    except OSError as exc:
        logger = await start_logger(STATE_DIR, RealClock(), (HOST, 0))
        _, port = logger.servers[0].address
        print(
            f"port {DEFAULT_PORT} is taken ({exc.strerror}): using the free port {port} instead"
            f' (choose one with: make demo ARGS="--listen {HOST}:PORT")',
            file=sys.stderr,
        )
        return logger


def _arguments(argv: list[str] | None) -> tuple[str, int] | None:
    parser = argparse.ArgumentParser(
        prog="python -m sondalog.demo", description="Serve a virtual ALA1 logger and show it."
    )
    parser.add_argument(
        "--listen",
        metavar="HOST:PORT",
        help=f"address to serve on (default {HOST}:{DEFAULT_PORT}, or a free port if taken)",
    )
    args = parser.parse_args(argv)
    if args.listen is None:
        return None
    try:
        return parse_listen(args.listen)
    except ValueError as exc:
        parser.error(f"--listen: {exc}")  # exits with status 2


async def main(listen: tuple[str, int] | None = None) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    try:
        logger = await _start(listen)
    except OSError as exc:
        where = format_address(*listen) if listen else f"{HOST}:{DEFAULT_PORT}"
        print(f"cannot serve the demo on {where}: {exc.strerror or exc}", file=sys.stderr)
        raise SystemExit(1) from exc
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
    asyncio.run(main(_arguments(None)))
