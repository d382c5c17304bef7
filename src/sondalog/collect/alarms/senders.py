"""Notification senders by kind (issue 21): a destination kind is one module and one
:func:`register_sender` call, like the collector's sinks.

A ``[[notify]]`` table's ``kind`` names its sender. The built-in ones are the modules
``sondalog/collect/alarms/send_KIND.py`` (``log``, ``email``, ``sms``, ``mqtt``,
``webhook``), imported only when a destination of that kind is configured; each registers
itself. A sender's ``send`` delivers one outbox :class:`~.outbox.Message` or raises
:class:`DeliveryError` (the message then waits and is retried with backoff); it reads its
destination's settings with the config reader (``sondalog.config.of(notify.settings)``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Protocol

from .outbox import Message
from .rules import Notify


class DeliveryError(Exception):
    """A notification could not be delivered now; the text says why (kept in the outbox)."""


class Sender(Protocol):
    """Delivers the notifications of one ``[[notify]]`` destination."""

    async def send(self, message: Message) -> None:
        """Deliver ``message``; raise :class:`DeliveryError` if it could not be."""
        ...

    async def close(self) -> None:
        """Release connections (the collector is stopping)."""
        ...


#: ``factory(notify) -> Sender`` for a destination of the kind.
SenderFactory = Callable[[Notify], Sender]

_REGISTERED: dict[str, SenderFactory] = {}


def register_sender(kind: str, factory: SenderFactory) -> None:
    """Make ``factory`` build the senders of ``[[notify]]`` tables with ``kind = KIND``."""
    _REGISTERED[kind] = factory


def find_sender(kind: str) -> SenderFactory | None:
    """The factory registered for ``kind`` (its module ``send_KIND`` imported on first use),
    or ``None``: nothing is built and nothing connects (the collector's file is checked with
    it at load)."""
    if kind not in _REGISTERED:
        try:
            importlib.import_module(f"{__package__}.send_{kind}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__package__}.send_{kind}":
                raise
    return _REGISTERED.get(kind)


def sender_for(notify: Notify) -> Sender:
    """A sender for ``notify`` (its kind's module is imported on first use)."""
    factory = find_sender(notify.kind)
    if factory is None:
        raise LookupError(f"no sender for notifications of kind {notify.kind!r}")
    return factory(notify)
