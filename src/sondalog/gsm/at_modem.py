"""The modem as its AT command sets see it (:mod:`~sondalog.gsm.modem_basic`,
:mod:`~sondalog.gsm.modem_calls`, :mod:`~sondalog.gsm.modem_sms`, :mod:`~sondalog.gsm.wip`):
its state (what the SIM and firmware say, the settings ``AT&F`` restores, the call, the
WIPsoft stack), :class:`AtModem` (what a handler may read, set and call on the
:class:`~sondalog.gsm.modem.Modem`, which implements it) and the handler tables. The command
modules import this module, never :mod:`sondalog.gsm.modem`; the byte-level machinery (line
editing, SMS input, data mode, ``+++``) stays private to the modem.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from sondalog.gsm import events as ev
from sondalog.gsm.atline import AtCommand, CmeError
from sondalog.gsm.sms import DEFAULT_SMSC
from sondalog.gsm.smsstore import SmsStore

#: CME error codes (27.007 §9.2).
NOT_ALLOWED = 3
NOT_SUPPORTED = 4
NO_NETWORK = 30


@dataclass(frozen=True, slots=True)
class ModemConfig:
    """What the SIM and the firmware say about themselves."""

    manufacturer: str = "WAVECOM MODEM"
    model: str = "MULTIBAND  900E  1800"
    revision: str = "R74_00gg.FXT002 2120060 062411 17:52"
    imei: str = "356938035643809"
    imsi: str = "230011234567890"
    smsc: str = DEFAULT_SMSC
    store_size: int = 30
    speed: int = 9600
    #: The CSD rate ``CONNECT`` names.
    data_rate: int = 9600
    #: Offset of the SMS timestamps shown by ``AT+CMGR`` (quarter hours).
    tz_quarters: int = 0
    #: Location area code and cell id ``AT+CREG=2`` shows (hex).
    lac: str = "0FA1"
    cell: str = "2B3C"
    #: The network's name and MCC+MNC (``AT+COPS?``).
    operator: str = "SONDALOG GSM"
    operator_code: str = "23001"


@dataclass(slots=True)
class Settings:
    """Command settings ``AT&F`` restores."""

    echo: bool = True
    verbose: bool = True
    quiet: bool = False
    cmee: int = 0
    text_mode: bool = False
    charset: str = "GSM"
    clip: bool = False
    crc: bool = False
    creg: int = 0
    cgreg: int = 0
    cops_format: int = 0
    cusd: bool = False
    auto_answer: int = 0
    cnmi: tuple[int, ...] = (2, 1, 0, 0, 0)
    csmp: tuple[int, ...] = (17, 167, 0, 0)
    extra: dict[str, str] = field(default_factory=dict)


@dataclass(slots=True)
class ActiveCall:
    """The modem's one call: ringing (incoming, not active), dialling, or connected."""

    kind: str
    caller: str | None
    incoming: bool
    active: bool = False
    rings: int = 0
    next_ring: float | None = None


@dataclass(slots=True)
class Socket:
    handle: int
    index: int
    ready: bool = False
    peer_closed: bool = False
    held: bytearray = field(default_factory=bytearray)


@dataclass(slots=True)
class Server:
    port: int
    first: int
    last: int


@dataclass(slots=True)
class WipState:
    stack: bool = False
    bearer_open: bool = False
    started: bool = False
    options: dict[int, str] = field(default_factory=dict)
    sockets: dict[int, Socket] = field(default_factory=dict)  # by index
    servers: dict[int, Server] = field(default_factory=dict)  # by server index
    next_handle: int = 1
    shutdown_pending: set[int] = field(default_factory=set)

    def by_handle(self, handle: int) -> Socket | None:
        return next((s for s in self.sockets.values() if s.handle == handle), None)


class AtModem(Protocol):
    """What the command handlers use of the modem (:class:`~sondalog.gsm.modem.Modem`)."""

    config: ModemConfig
    settings: Settings
    store: SmsStore
    smsc: str
    speed: int
    radio: bool
    registered: bool
    rssi: int
    mode: str
    call: ActiveCall | None
    wip: WipState
    data_target: int | None
    sms_destination: str
    sms_length: int

    def emit(self, data: bytes) -> None: ...

    def effect(self, effect: ev.Effect) -> None: ...

    def info(self, *lines: str) -> None: ...

    def final(self, code: str) -> None: ...

    def urc(self, text: str) -> None: ...

    def error_text(self, error: CmeError) -> str: ...

    def next_mr(self) -> int: ...

    def enter_data_mode(self, target: int | None, now: float) -> None: ...

    def leave_data_mode(self) -> None: ...

    def far_data(self, data: bytes) -> None: ...

    def drop_held_data(self) -> None: ...

    def start_sms_input(self) -> None: ...


Handler = Callable[[AtModem, AtCommand, float], list[str]]


def handler_into(table: dict[str, Handler]) -> Callable[..., Callable[[Handler], Handler]]:
    """A decorator registering a handler under one or more command names in ``table``."""

    def handler(*names: str) -> Callable[[Handler], Handler]:
        def register(fn: Handler) -> Handler:
            for name in names:
                table[name] = fn
            return fn

        return register

    return handler


def number_type(number: str) -> int:
    """Type of address: 145 international (``+``), 129 otherwise."""
    return 145 if number.startswith("+") else 129


def setting_value(cmd: AtCommand, allowed: tuple[int, ...]) -> int:
    """The one integer argument of a setting command; ``+CME ERROR: 3`` unless allowed."""
    values = cmd.ints(1)
    if values[0] is None or values[0] not in allowed:
        raise CmeError(NOT_ALLOWED)
    return values[0]
