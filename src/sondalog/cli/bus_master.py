"""Running one piece of work on a bus master for a command (``bus scan|ask|watch|config``):
open the master, run, close, and turn the bus's errors into the CLI's messages."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import TypeVar

import click

from sondalog.client.bus import BusMaster
from sondalog.client.bus_errors import BusError, ForeignPeer

T = TypeVar("T")


def run_master(
    url: str,
    host_id: str,
    timeout: float | None,
    work: Callable[[BusMaster], Awaitable[T]],
    foreign: Callable[[ForeignPeer], str],
) -> T:
    """``work`` on a master opened at ``url``; ``foreign`` says what a peer that is no
    HCTMPS1 bus means to the command."""

    async def go() -> T:
        master = await BusMaster.open(url, host_id, timeout=timeout)
        try:
            return await work(master)
        finally:
            await master.close()

    try:
        return asyncio.run(go())
    except ForeignPeer as exc:
        raise click.ClickException(foreign(exc)) from exc
    except BusError as exc:
        raise click.ClickException(str(exc)) from exc
    except OSError as exc:
        raise click.ClickException(f"cannot reach the bus at {url}: {exc}") from exc
