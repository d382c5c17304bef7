"""The network's phone side: what phones (the HTTP API, ``sondalog phone``) ask of the
network and what it tells them (docs/gsm.md "The network").

A :data:`Request` goes in through :meth:`Network.request <sondalog.gsm.network.Network.request>`
(in the served world: posted to the network's host). What comes back for the asking side is
typed: :class:`SmsSubmitted` carries the ids the SMS centre gave a submitted SMS,
:class:`CallPlaced` the id of a placed call; :class:`PhoneEvent` is everything a phone hears
later (an SMS, a call answered, its data, its end).
"""

from __future__ import annotations

from dataclasses import dataclass

from sondalog.gsm.sms import Sms


# -- requests ----------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class PhoneSms:
    """Phone ``sender`` sends ``text`` to ``to`` (a long text goes concatenated)."""

    sender: str
    to: str
    text: str


@dataclass(frozen=True, slots=True)
class PhoneCall:
    """Phone ``caller`` calls ``callee``; ``kind`` is ``voice`` or ``data``."""

    caller: str
    callee: str
    kind: str


@dataclass(frozen=True, slots=True)
class PhoneHangUp:
    call_id: int


@dataclass(frozen=True, slots=True)
class PhoneData:
    """Bytes from the phone's side of an answered data call."""

    call_id: int
    data: bytes


@dataclass(frozen=True, slots=True)
class Coverage:
    """Coverage on demand: one subscriber, or everyone (``number`` ``None``)."""

    number: str | None
    covered: bool


Request = PhoneSms | PhoneCall | PhoneHangUp | PhoneData | Coverage


# -- what the network tells the phone side -------------------------------------------------
@dataclass(frozen=True, slots=True)
class SmsSubmitted:
    """The SMS centre took a :class:`PhoneSms`: its ids (one per part), and whether it waits
    because the recipient cannot take it now (not reachable, or its store is full)."""

    sender: str
    to: str
    sms_ids: tuple[int, ...]
    queued: bool


@dataclass(frozen=True, slots=True)
class CallPlaced:
    """A :class:`PhoneCall` got id ``call_id`` (numbers normalised); it comes before anything
    the call itself makes (its ring, or its end when it fails at once)."""

    call_id: int
    caller: str
    callee: str
    kind: str


@dataclass(frozen=True, slots=True)
class PhoneEvent:
    """Something for a phone: ``kind`` is ``sms``, ``answered``, ``ended``, ``data``."""

    number: str
    kind: str
    call_id: int = 0
    data: bytes = b""
    reason: str = ""
    sms: Sms | None = None
