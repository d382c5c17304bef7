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

from sondalog.config import of

from .outbox import Message
from .rules import Notify
from .senders import Sender, register_sender

log = logging.getLogger("sondalog.alarms")
_LEVELS = {"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}


class LogSender:
    """Writes each notification as one log line at the destination's ``level``."""

    def __init__(self, notify: Notify) -> None:
        settings = of(notify.settings, where=f"notify.{notify.name}")
        self.level = _LEVELS[settings.text("level", "warning", choices=tuple(_LEVELS))]

    async def send(self, message: Message) -> None:
        alarm = f" [{message.alarm}]" if message.alarm else ""
        text = message.text.replace("\n", "; ")
        log.log(self.level, "alarm %s%s %s", message.what.upper(), alarm, text)

    async def close(self) -> None:
        return None


def _factory(notify: Notify) -> Sender:
    return LogSender(notify)


register_sender("log", _factory)
