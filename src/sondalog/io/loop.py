"""The event loop the serving commands run on (issue 11: ``pip install sondalog[fast]``).

:func:`run` is :func:`asyncio.run` on uvloop when uvloop is installed (the optional extra
``fast``), else on the standard loop. ``SONDALOG_LOOP=asyncio`` forces the standard loop,
``SONDALOG_LOOP=uvloop`` insists on uvloop (an error when it is absent). Every transport of
:mod:`sondalog.io` works on both (uvloop's transports are not :class:`asyncio.Transport`
subclasses: the TCP transport takes their interface). :func:`stop_on_signals` is the event
that SIGINT and SIGTERM set, on which the serving commands stop cleanly.
"""

from __future__ import annotations

import importlib
import logging
import os
from collections.abc import Coroutine
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    import asyncio

log = logging.getLogger(__name__)

T = TypeVar("T")

#: The environment variable that chooses the loop: ``auto`` (default), ``asyncio``, ``uvloop``.
ENV = "SONDALOG_LOOP"


class LoopChoiceError(ValueError):
    """``SONDALOG_LOOP`` names no loop, or uvloop that is not installed."""


def loop_name() -> str:
    """The loop :func:`run` would use: ``uvloop`` or ``asyncio``."""
    choice = os.environ.get(ENV, "auto").strip().lower() or "auto"
    if choice not in ("auto", "asyncio", "uvloop"):
        raise LoopChoiceError(f"{ENV}={choice!r}: use auto, asyncio or uvloop")
    if choice == "asyncio":
        return "asyncio"
    try:
        importlib.import_module("uvloop")
    except ImportError as exc:
        if choice == "uvloop":
            missing = "uvloop is not installed (pip install 'sondalog[fast]')"
            raise LoopChoiceError(f"{ENV}=uvloop but {missing}") from exc
        return "asyncio"
    return "uvloop"


def run(main: Coroutine[Any, Any, T]) -> T:
    """Run ``main`` to completion on the chosen loop (see the module docstring)."""
    import asyncio  # here: ``sondalog --help`` imports this module and needs no asyncio

    if loop_name() == "uvloop":
        import uvloop

        log.debug("event loop: uvloop")
        with asyncio.Runner(loop_factory=uvloop.new_event_loop) as runner:
            return runner.run(main)
    return asyncio.run(main)


def stop_on_signals() -> asyncio.Event:
    """An event that SIGINT and SIGTERM set, on the running loop (serve until it is set)."""
    import asyncio
    import signal

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    return stop
