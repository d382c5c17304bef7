"""What the modem and the network say to each other (the gsm notes (docs/gsm-notes.md) §1).

The modem core (:mod:`sondalog.gsm.modem`) returns *effects* toward the network; the network
core (:mod:`sondalog.gsm.network`) answers with *events* for the modem. Neither does I/O: the
composition (:mod:`sondalog.gsm.system`, or the runtime) carries one to the other. A modem has
at most one call at a time, so call messages carry no call id. TCP sockets are named by a
*handle*: the modem numbers the connections it opens from 1, the network numbers the ones it
hands to a listening modem from :data:`INCOMING_HANDLES`.
"""

from __future__ import annotations

from dataclasses import dataclass

from sondalog.gsm.pdu import Concat

INCOMING_HANDLES = 1_000_000

VOICE = "voice"
DATA = "data"


# -- modem -> network (effects) ----------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Radio:
    """``AT+CFUN=0/1``: the radio switched off or on (§6.11.5.2.2)."""

    on: bool


@dataclass(frozen=True, slots=True)
class SendSms:
    """An SMS submitted with ``AT+CMGS`` (text or PDU mode)."""

    to: str
    text: str
    mr: int
    alphabet: str = "gsm7"
    concat: Concat | None = None


@dataclass(frozen=True, slots=True)
class SmsAccepted:
    """The modem stored SMS ``sms_id`` (the SMS centre may forget it)."""

    sms_id: int


@dataclass(frozen=True, slots=True)
class SmsRejected:
    """The modem's store is full: SMS ``sms_id`` stays queued at the SMS centre."""

    sms_id: int


@dataclass(frozen=True, slots=True)
class StoreAvailable:
    """After a full store had an SMS deleted: send the queued SMS again."""


@dataclass(frozen=True, slots=True)
class Dial:
    """``ATD<number>`` (data) or ``ATD<number>;`` (voice)."""

    number: str
    kind: str


@dataclass(frozen=True, slots=True)
class Answer:
    """``ATA`` (or auto-answer) took the ringing call."""


@dataclass(frozen=True, slots=True)
class HangUp:
    """``ATH``: the call (ringing or connected) ends."""


@dataclass(frozen=True, slots=True)
class CallSend:
    """Bytes from the DTE in data mode of a data call."""

    data: bytes


@dataclass(frozen=True, slots=True)
class Ussd:
    """``AT+CUSD=1,"<code>"``: a USSD request."""

    code: str


@dataclass(frozen=True, slots=True)
class Attach:
    """``AT+WIPBR=4,6,0``: the GPRS bearer starts (PDP context with ``apn``)."""

    apn: str
    user: str = ""


@dataclass(frozen=True, slots=True)
class Detach:
    """``AT+WIPBR=5,6`` (or the stack or radio stopped): the GPRS bearer is down."""


@dataclass(frozen=True, slots=True)
class TcpOpen:
    """``AT+WIPCREATE=2,...``: connect ``handle`` to ``host:port``."""

    handle: int
    host: str
    port: int


@dataclass(frozen=True, slots=True)
class TcpListen:
    """``AT+WIPCREATE=3,...``: accept connections on the modem's ``port``."""

    port: int


@dataclass(frozen=True, slots=True)
class TcpUnlisten:
    """``AT+WIPCLOSE=3,...``: stop accepting on ``port``."""

    port: int


@dataclass(frozen=True, slots=True)
class TcpSend:
    data: bytes
    handle: int


@dataclass(frozen=True, slots=True)
class TcpClose:
    handle: int


Effect = (
    Radio
    | SendSms
    | SmsAccepted
    | SmsRejected
    | StoreAvailable
    | Dial
    | Answer
    | HangUp
    | CallSend
    | Ussd
    | Attach
    | Detach
    | TcpOpen
    | TcpListen
    | TcpUnlisten
    | TcpSend
    | TcpClose
)


# -- network -> modem (events) -----------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Registration:
    """Registered in the GSM network or not (radio on and coverage, §6.11.5.2)."""

    registered: bool


@dataclass(frozen=True, slots=True)
class Signal:
    """Received signal strength, ``+CSQ`` rssi 0..31 (99 unknown), §6.11.7."""

    rssi: int


@dataclass(frozen=True, slots=True)
class SmsDelivered:
    """An SMS for this subscriber; ``timestamp`` is the centre's POSIX time."""

    sms_id: int
    sender: str
    text: str
    timestamp: int
    alphabet: str = "gsm7"
    concat: Concat | None = None


@dataclass(frozen=True, slots=True)
class IncomingCall:
    caller: str | None
    kind: str


@dataclass(frozen=True, slots=True)
class CallConnected:
    """The far end answered the call this modem dialled."""


@dataclass(frozen=True, slots=True)
class CallEnded:
    """The call ended: ``hangup`` (far end), ``busy``, ``no answer``, ``unreachable``."""

    reason: str = "hangup"


@dataclass(frozen=True, slots=True)
class CallData:
    data: bytes


@dataclass(frozen=True, slots=True)
class UssdAnswer:
    """The network's answer to :class:`Ussd`; ``None``: the code is not supported."""

    text: str | None


@dataclass(frozen=True, slots=True)
class TcpConnected:
    handle: int


@dataclass(frozen=True, slots=True)
class TcpFailed:
    """:class:`TcpOpen` failed (WIPsoft error code, e.g. 842 host unreachable)."""

    handle: int
    code: int


@dataclass(frozen=True, slots=True)
class TcpIncoming:
    """A connection to the listening ``port``, named ``handle`` from now on."""

    port: int
    handle: int


@dataclass(frozen=True, slots=True)
class TcpData:
    handle: int
    data: bytes


@dataclass(frozen=True, slots=True)
class TcpClosed:
    """The peer closed ``handle`` (or the network dropped it)."""

    handle: int


Event = (
    Registration
    | Signal
    | SmsDelivered
    | IncomingCall
    | CallConnected
    | CallEnded
    | CallData
    | UssdAnswer
    | TcpConnected
    | TcpFailed
    | TcpIncoming
    | TcpData
    | TcpClosed
)
