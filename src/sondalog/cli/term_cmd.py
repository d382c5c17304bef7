"""``sondalog term URL``: a terminal to an ALA1 logger (parsing and printing only; the work is
in :mod:`sondalog.client`).

Interactive (stdin is a terminal): line editing and history (prompt_toolkit); every line typed
is sent with CR, and everything the logger sends is printed as it arrives, including answers
that come later (``pause``, §8.5.1) and echo (``+``, §3.4.2). Ctrl-C clears the line being
typed; Ctrl-D quits.

Scripted (stdin is not a terminal): each stdin line is sent as one command and its answer is
printed once it is complete: a final ``OK`` (plain or decorated, ``00154,OK``) or ``ERROR``
line, or a short silence after the last byte (``quiet`` answers). A command with no answer
within ``--timeout`` seconds (a failed ``check``, a ``quiet`` write) is reported on stderr and
makes the exit status 1. The command exits at the end of stdin. Example::

    printf 'read i version\\n' | sondalog term tcp://127.0.0.1:10001
    printf 'read i version\\n' | sondalog term "serial:///tmp/ala1?baud=9600"
"""

from __future__ import annotations

import asyncio
import contextlib
import sys
from typing import TextIO

import click

from sondalog.client import (
    Ala1Client,
    ClientError,
    Endpoint,
    parse_url,
)
from sondalog.client.ala1 import ConnectionLost


def _text(data: bytes) -> str:
    """Received bytes for a text terminal: CR LF becomes a newline."""
    return data.decode("latin-1").replace("\r\n", "\n")


@click.command()
@click.argument("url")
@click.option(
    "--timeout",
    type=click.FloatRange(min=0, min_open=True),
    default=2.0,
    show_default=True,
    help="Seconds to wait for each answer when reading commands from stdin.",
)
def term(url: str, timeout: float) -> None:
    """Talk to an ALA1 logger at URL (tcp://HOST:PORT, serial:///DEVICE?baud=9600).

    A serial URL also opens the pty of `logger serve --pty PATH`: serial://PATH?baud=9600.
    """
    try:
        endpoint = parse_url(url)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="URL") from exc
    try:
        status = asyncio.run(_session(endpoint, timeout, sys.stdin))
    except OSError as exc:
        raise click.ClickException(f"cannot connect to {endpoint}: {exc}") from exc
    sys.exit(status)


async def _session(endpoint: Endpoint, timeout: float, stdin: TextIO) -> int:
    client = await Ala1Client.connect(endpoint, timeout)
    if stdin.isatty():
        return await _interactive(client)
    return await _scripted(client, stdin, timeout)


async def _scripted(client: Ala1Client, stdin: TextIO, timeout: float) -> int:
    status = 0
    try:
        for raw_line in stdin:
            line = raw_line.rstrip("\r\n")
            if not line.strip(" "):
                continue  # the logger ignores empty lines: nothing to wait for
            try:
                answer = await client.exchange_raw(line, timeout=timeout)
            except ValueError as exc:
                click.echo(f"not sent: {exc}", err=True)
                status = 1
                continue
            if not answer:
                click.echo(f"no answer to {line!r}", err=True)
                status = 1
            click.echo(_text(answer), nl=False)
    except ConnectionLost as exc:
        click.echo(f"connection lost: {exc}", err=True)
        status = 1
    finally:
        await client.close()
    return status


async def _interactive(client: Ala1Client) -> int:
    from prompt_toolkit import PromptSession
    from prompt_toolkit.history import InMemoryHistory
    from prompt_toolkit.patch_stdout import patch_stdout

    session: PromptSession[str] = PromptSession(history=InMemoryHistory())
    closed = asyncio.Event()

    async def show_incoming() -> None:
        try:
            while True:
                data = await client.receive_raw(3600.0)
                if data:
                    print(_text(data), end="", flush=True)
        except ClientError:
            print("connection closed by the logger", flush=True)
            closed.set()

    with patch_stdout():
        reader = asyncio.create_task(show_incoming())
        try:
            while not closed.is_set():
                try:
                    line = await session.prompt_async("ala1> ")
                except KeyboardInterrupt:
                    continue
                except EOFError:
                    break
                if not closed.is_set():
                    await client.send_raw(line.encode("latin-1", "replace") + b"\r")
        finally:
            reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await reader
            await client.close()
    return 1 if closed.is_set() else 0
