"""One message's parameters (§6.14) and where it goes (§6.10, §6.11.5).

With ``com device local`` a message goes on the cable line (§6.14); with ``wavecom`` one
copy goes to each of its addresses of type ``sms`` or ``email`` (gsm.md §5). ``ringvoice``
and ``ringdata`` addresses start messages (§6.10.2.3-4); they are not destinations, nor is an
address without a value. An e-mail value may carry its own SMTP server after one more ``@``
(§6.10.3): it is passed to the carrier as the destination's ``server``.
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal
from typing import Protocol

from sondalog.ala1.moduleclock import to_seconds
from sondalog.ala1.outbox import Destination
from sondalog.ala1.tokens import parse_stamp
from sondalog.protocol.mail_address import split_email_value


class Settings(Protocol):
    def get(self, key: str) -> str: ...


class Module(Settings, Protocol):
    """The module's settings and whether its modem answers (ModuleState)."""

    modem_absent: bool


@dataclass(frozen=True)
class MessageConfig:
    """What message ``number`` is set to do."""

    number: int
    addresses: tuple[int, ...]
    command: int
    period: str
    start: float  # module seconds
    of_record: bool
    channel_function: str  # "NO" | "UP" | "DOWN"
    channel: int
    value: Decimal
    hysteresis: Decimal

    @property
    def watches(self) -> tuple[str, int, Decimal, Decimal] | None:
        if self.channel_function == "NO":
            return None
        return self.channel_function, self.channel, self.value, self.hysteresis


def load(settings: Settings, number: int) -> MessageConfig:
    prefix = f"message {number} "

    def get(name: str) -> str:
        return settings.get(prefix + name)

    return MessageConfig(
        number=number,
        addresses=tuple(int(a) for a in get("address").split(",") if a),
        command=int(get("command")),
        period=get("period"),
        start=to_seconds(parse_stamp(get("start"))),
        of_record=get("of record function") == "YES",
        channel_function=get("of channel function"),
        channel=int(get("of channel number")),
        value=Decimal(get("of channel value")),
        hysteresis=Decimal(get("of channel hysteresis")),
    )


def off(number: int) -> MessageConfig:
    """A message that nothing triggers (for a configuration that cannot be used)."""
    zero = Decimal(0)
    return MessageConfig(number, (), 1, "000000", 0.0, False, "NO", 1, zero, zero)


def is_local(module: Module) -> bool:
    """``com device local``, or a modem that does not answer (the line works as local)."""
    return module.get("com device") == "LOCAL" or module.modem_absent


def destinations(settings: Module, config: MessageConfig) -> tuple[Destination, ...]:
    """Where a sending of the message goes now (empty: nowhere)."""
    if is_local(settings):
        return (Destination("local"),)
    found: list[Destination] = []
    for number in config.addresses:
        kind = settings.get(f"address {number} type")
        value = settings.get(f"address {number} value")
        if not value:
            continue
        if kind == "SMS":
            found.append(Destination("sms", value))
        elif kind == "EMAIL":
            found.append(Destination("email", *split_email_value(value)))
    return tuple(found)
