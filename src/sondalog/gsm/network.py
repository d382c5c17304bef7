"""The GSM network as a pure core (the gsm notes (docs/gsm-notes.md) §1, §3, §6; manual §6.11.5).

Subscribers are E.164 numbers, each a modem (driven by :class:`~sondalog.gsm.modem.Modem`
effects) or a phone (driven by the runtime: the ``sondalog phone`` commands, the HTTP API).
The SMS centre keeps a queue per subscriber and delivers while the subscriber is registered
(radio on and in coverage); voice and data calls carry caller id and a data call bridges
bytes between its ends; USSD codes answer per subscriber, their text formatted with the
subscriber's credit; signal and credit are set by the caller; coverage can be taken away on
demand or on a schedule. IP goes through :class:`~sondalog.gsm.gateway.IpGateway`.

Every method takes ``now`` (POSIX seconds) where time matters and returns a list of typed
outputs (:data:`~sondalog.gsm.routing.NetOutput`): :class:`~sondalog.gsm.gateway.ModemEvent`
for a modem, :class:`~sondalog.gsm.phones.PhoneEvent` for a phone, gateway effects for the
runtime's sockets; :func:`sondalog.gsm.routing.route` carries them. The phone side's requests
(:data:`~sondalog.gsm.phones.Request`) go in through :meth:`Network.request`, which also
answers with the ids it gave (:class:`~sondalog.gsm.phones.SmsSubmitted`,
:class:`~sondalog.gsm.phones.CallPlaced`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

from sondalog.gsm import events as ev
from sondalog.gsm.gateway import IpEvent, IpGateway, ModemEvent
from sondalog.gsm.pdu import GSM7, UCS2, Concat
from sondalog.gsm.phones import (
    CallPlaced,
    Coverage,
    PhoneCall,
    PhoneData,
    PhoneEvent,
    PhoneHangUp,
    PhoneSms,
    Request,
    SmsSubmitted,
)
from sondalog.gsm.routing import NetOutput
from sondalog.gsm.sms import DEFAULT_SMSC, Sms, normalize, parts_of
from sondalog.protocol import gsm7

MODEM = "modem"
PHONE = "phone"
#: A call nobody answers ends after this many seconds.
NO_ANSWER_TIME = 60.0
DEFAULT_USSD = {"*101#": "Your credit is {credit:.2f} CZK."}


@dataclass(slots=True)
class Subscriber:
    number: str
    kind: str
    radio: bool = True
    covered: bool = True
    rssi: int = 18
    credit: float = 0.0
    ussd: dict[str, str] = field(default_factory=lambda: dict(DEFAULT_USSD))
    queue: deque[Sms] = field(default_factory=deque)
    delivered: list[Sms] = field(default_factory=list)
    in_flight: set[int] = field(default_factory=set)
    store_full: bool = False
    attached: bool = False
    call_id: int | None = None
    registered: bool = False

    @property
    def reachable(self) -> bool:
        return self.radio and self.covered


@dataclass(slots=True)
class Call:
    call_id: int
    caller: str
    callee: str
    kind: str
    active: bool = False
    deadline: float | None = None


@dataclass(frozen=True, slots=True)
class Outage:
    """No coverage from ``start`` to ``end`` for ``number`` (``None``: everyone)."""

    start: float
    end: float
    number: str | None = None


class Network:
    """Subscribers, the SMS centre, calls, USSD, coverage and the IP gateway."""

    def __init__(self, smsc: str = DEFAULT_SMSC, sms_price: float = 0.0) -> None:
        self.smsc = smsc
        self.sms_price = sms_price
        self.subscribers: dict[str, Subscriber] = {}
        self.calls: dict[int, Call] = {}
        self.outages: list[Outage] = []
        self.undeliverable: list[Sms] = []
        self.gateway = IpGateway()
        self._manual_cover: dict[str, bool] = {}
        self._next_sms = 1
        self._next_call = 1
        self._concat_ref = 0

    # -- subscribers ---------------------------------------------------------------------
    def add_modem(self, number: str, now: float, **kw: object) -> list[NetOutput]:
        """A modem subscriber (radio on, like a modem just powered)."""
        sub = self._add(number, MODEM, kw)
        return self._update(sub, now)

    def add_phone(self, number: str, **kw: object) -> None:
        sub = self._add(number, PHONE, kw)
        sub.registered = sub.reachable

    def _add(self, number: str, kind: str, kw: dict[str, object]) -> Subscriber:
        sub = Subscriber(normalize(number), kind)
        for key, value in kw.items():
            if not hasattr(sub, key):
                raise TypeError(f"unknown subscriber field {key!r}")
            setattr(sub, key, value)
        self.subscribers[sub.number] = sub
        return sub

    def subscriber(self, number: str) -> Subscriber:
        return self.subscribers[normalize(number)]

    def set_signal(self, number: str, rssi: int, now: float) -> list[NetOutput]:
        sub = self.subscriber(number)
        sub.rssi = max(0, min(31, int(rssi))) if rssi != 99 else 99
        return [ModemEvent(sub.number, ev.Signal(sub.rssi))] if sub.kind == MODEM else []

    def set_credit(self, number: str, credit: float) -> None:
        self.subscriber(number).credit = float(credit)

    def set_coverage(self, number: str | None, covered: bool, now: float) -> list[NetOutput]:
        """Coverage on demand: one subscriber, or everyone (``None``)."""
        targets = [self.subscriber(number)] if number else list(self.subscribers.values())
        out: list[NetOutput] = []
        for sub in targets:
            self._manual_cover[sub.number] = covered
            out += self._update(sub, now)
        return out

    def schedule_outage(self, start: float, end: float, number: str | None = None) -> None:
        self.outages.append(Outage(start, end, normalize(number) if number else None))

    def delivered(self, number: str) -> list[Sms]:
        """SMS delivered to ``number`` so far, oldest first."""
        return list(self.subscriber(number).delivered)

    def queued(self, number: str) -> list[Sms]:
        return list(self.subscriber(number).queue)

    # -- time ----------------------------------------------------------------------------
    def advance(self, now: float) -> list[NetOutput]:
        out: list[NetOutput] = []
        for sub in self.subscribers.values():
            out += self._update(sub, now)
        for call in list(self.calls.values()):
            if call.deadline is not None and now >= call.deadline:
                out += self._end_call(call, "no answer")
        return out

    def next_deadline(self, now: float) -> float | None:
        times = [c.deadline for c in self.calls.values() if c.deadline is not None]
        times += [t for o in self.outages for t in (o.start, o.end) if t > now]
        return min(times) if times else None

    def _covered(self, sub: Subscriber, now: float) -> bool:
        if not self._manual_cover.get(sub.number, True):
            return False
        return not any(
            o.start <= now < o.end and o.number in (None, sub.number) for o in self.outages
        )

    def _update(self, sub: Subscriber, now: float) -> list[NetOutput]:
        """Re-evaluate coverage and registration; deliver or drop on a change."""
        sub.covered = self._covered(sub, now)
        registered = sub.reachable
        out: list[NetOutput] = []
        if registered != sub.registered:
            sub.registered = registered
            if sub.kind == MODEM:
                out.append(ModemEvent(sub.number, ev.Registration(registered)))
                if registered:
                    out.append(ModemEvent(sub.number, ev.Signal(sub.rssi)))
            if not registered:
                sub.in_flight.clear()
                sub.attached = False
                out += self.gateway.drop(sub.number)
                if sub.call_id is not None:
                    out += self._end_call(self.calls[sub.call_id], "unreachable")
        if registered:
            out += self._deliver(sub, now)
        return out

    # -- the phone side ------------------------------------------------------------------
    def request(self, request: Request, now: float) -> list[NetOutput]:
        """A request of the phone side (the HTTP API, ``sondalog phone``); a submitted SMS
        is answered with its ids (:class:`SmsSubmitted`, after its deliveries), a placed
        call with its id (:class:`CallPlaced`, before its ring or its end)."""
        match request:
            case PhoneSms(sender, to, text):
                before = self._next_sms
                out = self.phone_sms(sender, to, text, now)
                ids = tuple(range(before, self._next_sms))
                queued = self._waits(to, ids)
                return [*out, SmsSubmitted(normalize(sender), normalize(to), ids, queued)]
            case PhoneCall(caller, callee, kind):
                call_id, out = self.phone_call(caller, callee, kind, now)
                placed = CallPlaced(call_id, normalize(caller), normalize(callee), kind)
                return [placed, *out]
            case PhoneHangUp(call_id):
                return self.phone_hang_up(call_id, now)
            case PhoneData(call_id, data):
                return self.phone_data(call_id, data)
            case Coverage(number, covered):
                return self.set_coverage(number, covered, now)

    def _waits(self, to: str, ids: tuple[int, ...]) -> bool:
        """Whether any of the SMS ``ids`` waits at the centre (not on its way to a modem)."""
        sub = self.subscribers.get(normalize(to))
        waiting = [] if sub is None else [s for s in sub.queue if s.sms_id not in sub.in_flight]
        return any(s.sms_id in ids for s in waiting)

    # -- SMS centre ----------------------------------------------------------------------
    def phone_sms(self, sender: str, to: str, text: str, now: float) -> list[NetOutput]:
        """A phone (or the HTTP API) sends an SMS: GSM-7 when the text allows, else UCS2;
        a text longer than one SMS goes as a concatenated SMS (parts of 153 septets or 67
        UCS2 characters, 23.040 §9.2.3.24.1)."""
        alphabet = GSM7 if gsm7.is_gsm7(text) else UCS2
        parts = parts_of(text, alphabet)
        if len(parts) == 1:
            return self._submit(normalize(sender), to, text, now, alphabet, None)
        self._concat_ref = (self._concat_ref + 1) % 256
        out: list[NetOutput] = []
        for seq, part in enumerate(parts, 1):
            concat = Concat(self._concat_ref, len(parts), seq)
            out += self._submit(normalize(sender), to, part, now, alphabet, concat)
        return out

    def _submit(
        self, sender: str, to: str, text: str, now: float, alphabet: str, concat: Concat | None
    ) -> list[NetOutput]:
        sms = Sms(self._next_sms, sender, normalize(to), text, int(now), alphabet, concat)
        self._next_sms += 1
        sub = self.subscribers.get(sms.to)
        if sub is None:
            self.undeliverable.append(sms)
            return []
        sub.queue.append(sms)
        return self._deliver(sub, now) if sub.registered else []

    def _deliver(self, sub: Subscriber, now: float) -> list[NetOutput]:
        if sub.kind == PHONE:
            out: list[NetOutput] = []
            while sub.queue:
                sms = sub.queue.popleft()
                sub.delivered.append(sms)
                out.append(PhoneEvent(sub.number, "sms", sms=sms))
            return out
        if sub.store_full:
            return []
        out = []
        for sms in sub.queue:
            if sms.sms_id not in sub.in_flight:
                sub.in_flight.add(sms.sms_id)
                event = ev.SmsDelivered(
                    sms.sms_id, sms.sender, sms.text, sms.timestamp, sms.alphabet, sms.concat
                )
                out.append(ModemEvent(sub.number, event))
        return out

    # -- from modems ---------------------------------------------------------------------
    def from_modem(self, number: str, effect: ev.Effect, now: float) -> list[NetOutput]:
        """An effect of subscriber ``number``'s modem."""
        sub = self.subscriber(number)
        if isinstance(effect, ev.Radio):
            sub.radio = effect.on
            return self._update(sub, now)
        if isinstance(effect, ev.SendSms):
            if not sub.registered:
                return []
            sub.credit -= self.sms_price
            return self._submit(
                sub.number, effect.to, effect.text, now, effect.alphabet, effect.concat
            )
        if isinstance(effect, ev.SmsAccepted | ev.SmsRejected):
            sub.in_flight.discard(effect.sms_id)
            if isinstance(effect, ev.SmsRejected):
                sub.store_full = True
                return []
            for sms in list(sub.queue):
                if sms.sms_id == effect.sms_id:
                    sub.queue.remove(sms)
                    sub.delivered.append(sms)
            return []
        if isinstance(effect, ev.StoreAvailable):
            sub.store_full = False
            return self._deliver(sub, now) if sub.registered else []
        if isinstance(effect, ev.Ussd):
            template = sub.ussd.get(effect.code)
            text = template.format(credit=sub.credit) if template is not None else None
            return [ModemEvent(sub.number, ev.UssdAnswer(text))]
        if isinstance(effect, ev.Attach | ev.Detach):
            sub.attached = isinstance(effect, ev.Attach) and sub.registered
            return [] if sub.attached else [*self.gateway.drop(sub.number)]
        if isinstance(effect, ev.TcpOpen):
            return [*self.gateway.open(sub.number, effect.handle, effect.host, effect.port)]
        if isinstance(effect, ev.TcpSend):
            return [*self.gateway.send(sub.number, effect.handle, effect.data)]
        if isinstance(effect, ev.TcpClose):
            return [*self.gateway.close(sub.number, effect.handle)]
        if isinstance(effect, ev.TcpListen):
            return [*self.gateway.listen(sub.number, effect.port)] if sub.attached else []
        if isinstance(effect, ev.TcpUnlisten):
            return [*self.gateway.unlisten(sub.number, effect.port)]
        return self._modem_call(sub, effect, now)

    def ip_event(self, event: IpEvent, now: float) -> list[NetOutput]:
        """A socket event from the runtime."""
        return [*self.gateway.ip_event(event)]

    # -- calls ---------------------------------------------------------------------------
    def phone_call(
        self, caller: str, callee: str, kind: str, now: float
    ) -> tuple[int, list[NetOutput]]:
        """A phone calls; returns the call id (the phone hears ``ended`` if it fails)."""
        call = Call(self._next_call, normalize(caller), normalize(callee), kind)
        self._next_call += 1
        self.calls[call.call_id] = call
        target = self.subscribers.get(call.callee)
        if target is None or target.kind != MODEM or not target.registered:
            return call.call_id, self._end_call(call, "unreachable")
        if target.call_id is not None:
            return call.call_id, self._end_call(call, "busy")
        target.call_id = call.call_id
        call.deadline = now + NO_ANSWER_TIME
        return call.call_id, [ModemEvent(target.number, ev.IncomingCall(call.caller, kind))]

    def phone_hang_up(self, call_id: int, now: float) -> list[NetOutput]:
        call = self.calls.get(call_id)
        return [] if call is None else self._end_call(call, "hangup", by=call.caller)

    def phone_data(self, call_id: int, data: bytes) -> list[NetOutput]:
        call = self.calls.get(call_id)
        if call is None or not call.active or call.kind != ev.DATA:
            return []
        return [ModemEvent(call.callee, ev.CallData(data))]

    def _modem_call(self, sub: Subscriber, effect: ev.Effect, now: float) -> list[NetOutput]:
        call = self.calls.get(sub.call_id) if sub.call_id is not None else None
        if isinstance(effect, ev.Dial):
            return self._modem_dial(sub, effect, now)
        if call is None:
            return []
        if isinstance(effect, ev.Answer) and sub.number == call.callee and not call.active:
            call.active = True
            call.deadline = None
            return self._tell(call.caller, call, ev.CallConnected(), "answered")
        if isinstance(effect, ev.HangUp):
            return self._end_call(call, "hangup", by=sub.number)
        if isinstance(effect, ev.CallSend) and call.active:
            other = call.caller if sub.number == call.callee else call.callee
            return self._tell(other, call, ev.CallData(effect.data), "data", effect.data)
        return []

    def _modem_dial(self, sub: Subscriber, dial: ev.Dial, now: float) -> list[NetOutput]:
        call = Call(self._next_call, sub.number, normalize(dial.number), dial.kind)
        self._next_call += 1
        self.calls[call.call_id] = call
        sub.call_id = call.call_id
        target = self.subscribers.get(call.callee)
        if target is None or not target.registered:
            return self._end_call(call, "no carrier")
        if target.call_id is not None:
            return self._end_call(call, "busy")
        target.call_id = call.call_id
        if target.kind == PHONE:  # a phone answers voice at once and cannot take data
            if dial.kind == ev.DATA:
                return self._end_call(call, "no carrier")
            call.active = True
            return [ModemEvent(sub.number, ev.CallConnected())]
        call.deadline = now + NO_ANSWER_TIME
        return [ModemEvent(target.number, ev.IncomingCall(sub.number, dial.kind))]

    def _tell(
        self, number: str, call: Call, event: ev.Event, kind: str, data: bytes = b""
    ) -> list[NetOutput]:
        sub = self.subscribers.get(number)
        if sub is not None and sub.kind == MODEM:
            return [ModemEvent(number, event)]
        return [PhoneEvent(number, kind, call.call_id, data)]

    def _end_call(self, call: Call, reason: str, by: str | None = None) -> list[NetOutput]:
        self.calls.pop(call.call_id, None)
        out: list[NetOutput] = []
        for number in (call.caller, call.callee):
            sub = self.subscribers.get(number)
            involved = sub is not None and sub.call_id == call.call_id
            if involved:
                sub.call_id = None  # type: ignore[union-attr]
            if number == by or not (involved or number == call.caller):
                continue
            ended = ev.CallEnded(reason if number == call.caller else "hangup")
            if sub is not None and sub.kind == MODEM:
                if sub.registered or number == call.caller:
                    out.append(ModemEvent(number, ended))
            else:
                out.append(PhoneEvent(number, "ended", call.call_id, reason=reason))
        return out
