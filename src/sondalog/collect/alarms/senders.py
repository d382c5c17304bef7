"""Notification senders by kind (issue 21): a destination kind is one module and one
:func:`register_sender` call, like the collector's sinks (:mod:`sondalog.collect.sinks`).

A registration carries all the collector needs to know about the kind:

- its ``kind`` (``[[notify]] kind = "email"``);
- its settings' parsing, ``parse(table) -> settings``: ``table`` is the ``[[notify]]``
  table (:class:`sondalog.config.Table`, typed getters). It refuses unknown keys
  (``table.keys(COMMON_KEYS | its own)``, with a "did you mean"), returns the kind's own
  typed settings and raises :class:`~sondalog.config.ConfigError` (``FILE:LINE:
  notify[i].key: message``). The fields every kind takes (:data:`COMMON_KEYS`: name,
  repeat, quiet, rate, retries...) are read by :mod:`.parse_notify`;
- its factory, ``factory(notify) -> Sender``: a sender for the destination, whose
  :attr:`~.rules.Notify.settings` are what ``parse`` returned (nothing connects yet).

The built-in kinds are the modules ``sondalog/collect/alarms/send_KIND.py`` (``log``,
``email``, ``sms``, ``mqtt``, ``webhook``), imported only when a destination of that kind
is configured; each registers itself. A sender's ``send`` delivers one outbox
:class:`~.outbox.Message` or raises :class:`DeliveryError` (the message then waits and is
retried with backoff).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from sondalog.config import Table

from .outbox import Message
from .rules import Notify

S = TypeVar("S")
#: ``parse(table) -> settings``: the kind's own keys of a ``[[notify]]`` table checked.
Parse = Callable[[Table], S]

#: The keys every ``[[notify]]`` table may have, whatever its kind (:mod:`.parse_notify`).
COMMON_KEYS = frozenset(
    {"name", "kind", "repeat", "quiet", "quiet_mode", "rate", "retries", "backoff"}
    | {"backoff_max", "timezone"}
)
#: Where the built-in sender modules are: ``send_KIND.py`` registers the kind ``KIND``.
_PACKAGE = __name__.rpartition(".")[0]
_PREFIX = "send_"


class DeliveryError(Exception):
    """A notification could not be delivered now; the text says why (kept in the outbox)."""


class SenderUnavailable(LookupError):
    """A built-in kind whose module cannot be imported (a dependency is missing)."""


class Sender(Protocol):
    """Delivers the notifications of one ``[[notify]]`` destination."""

    async def send(self, message: Message) -> None:
        """Deliver ``message``; raise :class:`DeliveryError` if it could not be."""
        ...

    async def close(self) -> None:
        """Release connections (the collector is stopping)."""
        ...


@dataclass(frozen=True, slots=True)
class SenderKind(Generic[S]):
    """One registered destination kind: its name, its settings' parsing, its factory."""

    kind: str
    parse: Parse[S]
    factory: Callable[[Notify[S]], Sender]


_REGISTERED: dict[str, SenderKind[Any]] = {}


def register_sender(kind: str, factory: Callable[[Notify[S]], Sender], parse: Parse[S]) -> None:
    """Make ``[[notify]]`` tables with ``kind = KIND`` read by ``parse`` and sent by the
    senders ``factory`` builds (a later registration replaces it)."""
    _REGISTERED[kind] = SenderKind(kind, parse, factory)


def builtin_kinds() -> list[str]:
    """The built-in kinds: the ``send_KIND`` modules (none is imported)."""
    package = importlib.import_module(_PACKAGE)
    return [
        info.name.removeprefix(_PREFIX)
        for info in pkgutil.iter_modules(package.__path__)
        if info.name.startswith(_PREFIX)
    ]


def known_kinds() -> list[str]:
    """Every kind: the built-in ones and the registered ones, sorted."""
    return sorted({*builtin_kinds(), *_REGISTERED})


def find_sender(kind: str) -> SenderKind[Any] | None:
    """The registration of ``kind`` (its module ``send_KIND`` imported on first use), or
    ``None`` for a kind no sender has; raises :class:`SenderUnavailable` for a built-in
    kind whose module needs what is not installed."""
    found = _REGISTERED.get(kind)
    if found is not None or kind not in builtin_kinds():
        return found
    module = f"{_PACKAGE}.{_PREFIX}{kind}"
    try:
        importlib.import_module(module)
    except ModuleNotFoundError as exc:
        raise SenderUnavailable(
            f"the {kind} sender is not available: cannot import {exc.name} ({module})"
        ) from None
    return _REGISTERED.get(kind)


def sender_for(notify: Notify[Any]) -> Sender:
    """A sender for ``notify`` (its kind's module is imported on first use)."""
    found = find_sender(notify.kind)
    if found is None:
        raise LookupError(f"no sender for notifications of kind {notify.kind!r}")
    return found.factory(notify)
