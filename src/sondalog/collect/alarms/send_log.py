"""``kind = "log"`` destinations: one log line per notification (issue 21).

::

    [[notify]]
    name = "log"
    kind = "log"
    level = "warning"       # info, warning, error

The line goes to the logger ``sondalog.alarms`` (the collector's log: stderr, or journald
under systemd): ``alarm RAISED [3f2a9c1b12] threshold F*/Air above 40: ...``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from sondalog.config import Table

from .outbox import Message
from .rules import Notify
from .senders import COMMON_KEYS, Sender, register_sender

log = logging.getLogger("sondalog.alarms")
_LEVELS = {"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}


@dataclass(frozen=True, slots=True)
class LogSettings:
    """A ``log`` destination's own keys, checked: the line's level (``logging.WARNING``)."""

    level: int = logging.WARNING


def parse(t: Table) -> LogSettings:
    """A ``log`` table's own keys (raises ``ConfigError``)."""
    t.keys(COMMON_KEYS | {"level"})
    return LogSettings(_LEVELS[t.text("level", "warning", choices=tuple(_LEVELS))])


class LogSender:
    """Writes each notification as one log line at the destination's ``level``."""

    def __init__(self, settings: LogSettings) -> None:
        self.level = settings.level

    async def send(self, message: Message) -> None:
        alarm = f" [{message.alarm}]" if message.alarm else ""
        text = message.text.replace("\n", "; ")
        log.log(self.level, "alarm %s%s %s", message.what.upper(), alarm, text)

    async def close(self) -> None:
        return None


def _factory(notify: Notify[LogSettings]) -> Sender:
    return LogSender(notify.settings)


register_sender("log", _factory, parse)
