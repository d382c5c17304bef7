"""What the driver does, one job at a time, as AT conversations (gsm.md §2-§6).

Each job is a generator of :mod:`~sondalog.ala1.modem.atio` requests. ``d`` is the driver
(:class:`~sondalog.ala1.modem.host.Driver`); ``d.now`` is the time of the resumption. The
steps jobs share with the mail jobs (radio, registration, running a command) are in
:mod:`~sondalog.ala1.modem.steps`.
"""

from __future__ import annotations

import logging
from collections.abc import Generator

from sondalog.ala1.modem import mailjobs
from sondalog.ala1.modem.atio import (
    CONNECT_FINALS,
    CTRL_Z,
    REPLY_MAX_AGE,
    REPLY_TRIES,
    At,
    Job,
    PendingReply,
    Request,
    Send,
    Sleep,
    Urc,
    Write,
    as_reply,
    at,
    reply_backoff,
)
from sondalog.ala1.modem.credit import credit_from_answer, parse_credit_code, rssi_from_csq
from sondalog.ala1.modem.host import Driver
from sondalog.ala1.modem.session import data_session, leave_data_mode
from sondalog.ala1.modem.steps import execute, radio, registered
from sondalog.ala1.modem.text import gsm7_text, split_sms
from sondalog.ala1.outbox import Outgoing
from sondalog.protocol.mail_command import BoundedCommand, extract_command

log = logging.getLogger(__name__)

#: After a command went unanswered: quiet before the probe, so a late answer is not taken
#: for the probe's (gsm.md §7).
RESYNC_QUIET = 2.0
#: How long answers to commands that timed out are waited for before a probe (a modem
#: that stalled answers them all when it comes back; after this they count as lost).
LATE_ANSWERS = 90.0
ESC = b"\x1b"
#: No answer to ``AT`` within this many seconds: no modem (§6.11.5.2.1).
PROBE_TIMEOUT = 1.0
SETUP = ("ATE0", "AT+CMEE=1", "AT+CMGF=1", "AT+CLIP=1", "AT+CRC=1", "AT+CNMI=2,1,0,0,0",
         "AT+CREG=1")  # fmt: skip


def probe(d: Driver) -> Job:
    """§6.11.5.2.1: is a modem there? ``AT`` answered within 1 s."""
    if d.reader.raw and not (yield from leave_data_mode(d)):  # gsm.md §7: no AT in it
        d.found(False)
        d.keep_looking()
        return
    resync, d.resync = d.resync, False
    if resync:  # a command went unanswered: its late answer passes first, unread
        yield Sleep(RESYNC_QUIET)
    late = resync or d.heard  # a modem is there: answers to commands that timed out
    while late and d.outstanding and d.now < d.last_timeout + LATE_ANSWERS:
        yield Sleep(1.0)  # may still come, and are not the probe's
    d.outstanding = 0
    yield Write(ESC)  # ends a "> " prompt the modem may still wait at (gammu does the same)
    reply = yield from at("AT", PROBE_TIMEOUT)
    if not reply.final and (resync or d.present is False):
        # a modem that answered before may be in data mode the driver lost track of (the
        # first probe stays 1 s: §6.11.5.2.1)
        yield from leave_data_mode(d)
        reply = yield from at("AT", PROBE_TIMEOUT)
    if reply.final:
        d.stray_finals = 0
        yield Sleep(PROBE_TIMEOUT)
        if d.stray_finals:  # another answer came after: that one was late, so maybe ours
            d.out_of_step("an answer after the probe's")
            return
    d.found(reply.final != "")
    if not reply.final and resync:
        d.keep_looking()


def hang_up(d: Driver) -> Job:
    """The modem is in data mode with no job of the driver's (a ``CONNECT`` that came late):
    leave it and hang up; the set-up runs again after (gsm.md §7)."""
    log.warning("modem in data mode outside a session: leaving it")
    if (yield from leave_data_mode(d)):
        yield from at("ATH")


def init(d: Driver, device: str) -> Job:
    """Set the modem up (echo off, errors, text-mode SMS, caller id...), then its idle mode."""
    for line in SETUP:
        if (yield from at(line)).final == "":
            return
    smsc = d.host.setting("com network smc").strip()
    if smsc:
        yield from at(f'AT+CSCA="{smsc}"')
    on = device != "WAVECOM40"
    d.radio = not on  # force the radio command below
    yield from radio(d, on)
    if device == "WAVECOM42":
        yield from mailjobs.gprs_up(d)
    elif d.gprs:
        yield from mailjobs.gprs_down(d)
    d.applied = device
    d.listing_due = True  # gsm.md §7: SMS stored before AT+CNMI had no notice
    d.drop_urcs("RING")  # rang before AT+CRC=1: a ringing call rings again, with its kind


def list_store(d: Driver) -> Job:
    """gsm.md §7: every SMS in the store, oldest first, read, deleted and handled as a
    ``+CMTI`` would have it (``+CMTI`` is only a hint)."""
    reply = yield from at('AT+CMGL="ALL"', 30.0)
    if not reply.ok:
        return
    found: list[tuple[str, int]] = []
    for line in reply.lines:
        if not line.startswith("+CMGL:"):
            continue
        fields = line[6:].split(",")
        quoted = line.split('"')
        stamp = quoted[7] if len(quoted) > 7 else ""  # "yy/MM/dd,hh:mm:ss+zz"
        if fields[0].strip().isdigit():
            found.append((stamp, int(fields[0])))
    for _, index in sorted(found):
        yield from read_sms(d, index)


def ready(d: Driver) -> Generator[Request, object, bool]:
    """:func:`registered`, then the :func:`readings` taken: whether the modem can send."""
    ok = yield from registered(d)
    if ok:
        yield from readings(d)
    return ok


def readings(d: Driver) -> Generator[Request, object, None]:
    """gsm.md §6: signal by ``AT+CSQ``, credit by USSD when ``com status sim credit code``."""
    reply = yield from at("AT+CSQ")
    line = reply.info("+CSQ:")
    if reply.ok and line is not None:
        d.readings.signal = rssi_from_csq(line)
    code = parse_credit_code(d.host.setting("com status sim credit code"))
    if code is None or '"' in code.code:
        return
    if not (yield from at(f'AT+CUSD=1,"{code.code}",15')).ok:
        return
    answer = yield Urc(("+CUSD:",), 30.0)
    if isinstance(answer, str) and answer.count('"') >= 2:
        credit = credit_from_answer(answer.split('"')[1], code)
        if credit is not None:
            d.readings.credit = credit


def send_sms(
    d: Driver, number: str, text: str, reply: PendingReply | None = None
) -> Generator[Request, object, bool]:
    """gsm.md §4: several SMS of at most 160 GSM-7 characters, in order; others become ``?``.
    With ``reply``: the parts it already sent are skipped, the ones sent now counted."""
    if not valid_number(number):
        return False
    parts = split_sms(gsm7_text(text))
    for part in parts[reply.parts_sent if reply is not None else 0 :]:
        prompt = as_reply((yield At(f'AT+CMGS="{number}"', 10.0, prompt=True)))
        if prompt.final != ">":
            return False
        data = part.encode("latin-1", "replace") + CTRL_Z
        if not as_reply((yield Send(data, 60.0))).ok:
            return False
        if reply is not None:
            reply.parts_sent += 1
    return True


def valid_number(number: str) -> bool:
    return bool(number) and not any(c in number for c in '"\r\n')


def deliver(d: Driver, item: Outgoing) -> Job:
    """One Outbox sending: every ``sms`` and ``email`` destination; then ``done``."""
    ok = yield from ready(d)
    subject = item.subject if item.subject is not None else d.host.setting("email send subject")
    for dest in item.destinations:
        if not ok:
            break
        if dest.kind == "sms":
            ok = yield from send_sms(d, dest.address, item.body)
        elif dest.kind == "email":
            ok = yield from mailjobs.send_mail(d, dest.address, dest.server, subject, item.body)
    d.host.outbox.done(item.ident, ok)


def read_sms(d: Driver, index: int) -> Job:
    """§3.4.6.1: read, delete, run the bounded command, answer by SMS or e-mail."""
    reply = yield from at(f"AT+CMGR={index}")
    header = reply.info("+CMGR:")
    if (reply.ok and header is None) or reply.final == "ERROR":
        # an OK without the SMS is a late answer; a bare ERROR (the modem gives +CMS ERROR
        # since AT+CMEE=1) a command line garbled on the way: out of step (gsm.md §7)
        d.listing_due = True
        d.out_of_step(f"AT+CMGR={index} answered {reply.final} without an SMS")
        return
    if not reply.ok or header is None:
        return  # nothing there (+CMS ERROR: 321): nothing to delete either
    yield from at(f"AT+CMGD={index}")
    fields = header.split('"')
    sender = fields[3] if len(fields) > 3 else ""
    text = "\n".join(reply.lines[reply.lines.index(header) + 1 :])
    setting = d.host.setting
    found = extract_command(
        text,
        setting("sms command boundary"),
        setting("sms email address start"),
        setting("sms email address end"),
    )
    if not isinstance(found, BoundedCommand):
        return  # §6.12.1: an SMS without a bounded command is ignored
    answer = yield from execute(d, found.command)
    if not answer:
        return
    if found.return_address is not None:
        d.replies.append(PendingReply("email", found.return_address, answer, d.now))
        return
    if not valid_number(sender):
        log.warning("SMS command from %r: no number to answer", sender)
        return
    yield from send_reply(d, PendingReply("sms", sender, answer, d.now))


def send_reply(d: Driver, reply: PendingReply) -> Job:
    """One try at a reply; a failed one is kept for later, within bounds (gsm.md §7)."""
    reply.tries += 1
    sent = False
    if (yield from ready(d)):
        if reply.kind == "sms":
            sent = yield from send_sms(d, reply.address, reply.body, reply)
        else:
            subject = d.host.setting("email send subject")
            sent = yield from mailjobs.send_mail(d, reply.address, None, subject, reply.body)
    if sent:
        return
    if reply.tries >= REPLY_TRIES or d.now - reply.first >= REPLY_MAX_AGE:
        log.warning("reply to %s dropped after %d tries: %r", reply.address, reply.tries, reply)
        return
    reply.next_try = d.now + reply_backoff(reply.tries)
    d.replies.append(reply)


def call(d: Driver, kind: str, number: str) -> Job:
    """§6.10.2.3-4, §3.4.6.3: ring triggers, or a command session over a data call."""
    message = d.host.ring_message(kind, number) if number else None
    if kind == "voice" or message is not None:
        yield from at("ATH")
        if message is not None:
            d.host.run_message(message, d.now)
        return
    reply = as_reply((yield At("ATA", 30.0, finals=CONNECT_FINALS)))
    if reply.final.startswith("CONNECT"):
        yield from data_session(d, socket=None)
    yield from readings(d)


def socket_session(d: Driver, index: int) -> Job:
    """§3.4.6.4: a connection to port 10001 (``wavecom42``) is a command session."""
    reply = as_reply((yield At(f"AT+WIPDATA=2,{index},1", finals=CONNECT_FINALS)))
    if reply.final.startswith("CONNECT"):
        yield from data_session(d, socket=index)
    else:
        yield from at(f"AT+WIPCLOSE=2,{index}")
