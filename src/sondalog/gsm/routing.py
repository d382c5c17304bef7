"""The network's typed output and the one router that carries it (docs/gsm.md "Composition").

Every :class:`~sondalog.gsm.network.Network` method returns a list of :data:`NetOutput`: an
event for a subscriber's modem (:class:`~sondalog.gsm.gateway.ModemEvent`), something for
the phone side (:class:`~sondalog.gsm.phones.PhoneEvent`, and the answers to a request:
:class:`~sondalog.gsm.phones.SmsSubmitted`, :class:`~sondalog.gsm.phones.CallPlaced`) or a
socket effect of the IP gateway (:data:`~sondalog.gsm.gateway.IpEffect`).

:func:`route` is the only place that tells them apart. A composition says where each kind
goes by implementing :class:`Destinations`: the pure one (:class:`~sondalog.gsm.system.GsmSystem`)
calls the modem cores directly and collects the rest; the served one
(:class:`sondalog.app.gsm.GsmRuntime`) posts to the modems' hosts, the call bridges and real
sockets.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Protocol, assert_never

from sondalog.gsm import events as ev
from sondalog.gsm.gateway import Close, Connect, IpEffect, Listen, ModemEvent, Send, Unlisten
from sondalog.gsm.phones import CallPlaced, PhoneEvent, SmsSubmitted

#: Everything the network says.
NetOutput = ModemEvent | PhoneEvent | SmsSubmitted | CallPlaced | IpEffect


class Destinations(Protocol):
    """Where a composition carries each kind of the network's output."""

    def to_modem(self, number: str, event: ev.Event) -> None:
        """An event for the modem of subscriber ``number``."""
        ...

    def to_phone(self, event: PhoneEvent) -> None:
        """An SMS or call event for a phone."""
        ...

    def to_ip(self, effect: IpEffect) -> None:
        """A socket effect of the IP gateway (connect, send, close, listen, unlisten)."""
        ...

    def sms_submitted(self, reply: SmsSubmitted) -> None:
        """The ids of an SMS a phone submitted."""
        ...

    def call_placed(self, reply: CallPlaced) -> None:
        """The id of a call a phone placed (before anything the call makes)."""
        ...


def route(outputs: Iterable[NetOutput], to: Destinations) -> None:
    """Carry each output, in order, to its destination."""
    for output in outputs:
        match output:
            case ModemEvent():
                to.to_modem(output.number, output.event)
            case PhoneEvent():
                to.to_phone(output)
            case SmsSubmitted():
                to.sms_submitted(output)
            case CallPlaced():
                to.call_placed(output)
            case Connect() | Send() | Close() | Listen() | Unlisten():
                to.to_ip(output)
            case _:
                assert_never(output)
