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


#: The parameters of a message that make its configuration, in :class:`MessageConfig` order.
_NAMES = (
    "address", "command", "period", "start", "of record function", "of channel function",
    "of channel number", "of channel value", "of channel hysteresis",
)  # fmt: skip
#: Configurations by their number and values: a fleet's loggers, whose messages are mostly
#: at their factory values, share one object for each (issue 24). Bounded.
_SHARED: dict[tuple[str, ...], MessageConfig] = {}
_SHARED_MAX = 4096
_KEYS: dict[int, tuple[str, ...]] = {}  # message number -> its parameters' keys


def load(settings: Settings, number: int) -> MessageConfig:
    keys = _KEYS.get(number)
    if keys is None:  # made once: their hashes are kept, a fleet reads them all at start
        keys = _KEYS[number] = tuple(f"message {number} {name}" for name in _NAMES)
    raw = (str(number), *map(settings.get, keys))
    config = _SHARED.get(raw)
    if config is None:
        config = _parse(number, *raw[1:])
        if len(_SHARED) < _SHARED_MAX:
            _SHARED[raw] = config  # (frozen: sharing it is safe)
    return config


def _parse(
    number: int,
    address: str,
    command: str,
    period: str,
    start: str,
    of_record: str,
    function: str,
    channel: str,
    value: str,
    hysteresis: str,
) -> MessageConfig:
    return MessageConfig(
        number=number,
        addresses=tuple(int(a) for a in address.split(",") if a),
        command=int(command),
        period=period,
        start=to_seconds(parse_stamp(start)),
        of_record=of_record == "YES",
        channel_function=function,
        channel=int(channel),
        value=Decimal(value),
        hysteresis=Decimal(hysteresis),
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
