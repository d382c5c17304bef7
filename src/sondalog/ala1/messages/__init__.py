"""Messages the module sends by itself (§6.14): triggers, bodies, blocking, lastread shift.

:class:`Messages` decides what to send and when, and puts each sending in the engine's
:class:`~sondalog.ala1.outbox.Outbox`; carriers (the cable line, the modem driver) deliver.
"""

from sondalog.ala1.messages.controller import Messages

__all__ = ["Messages"]
