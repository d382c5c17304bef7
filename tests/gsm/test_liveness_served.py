"""Issue 20: the modem driver's liveness (gsm.md §7 "Never miss, never stick") on the SERVED
example world: a real ``sondalog serve examples/gsm-site.toml`` (free ports, temp state)
driven through its HTTP API, the logger's cable line and data-call bridges.

Each test is one symptom of the issue; each ends by asserting that the SMS commands were
answered exactly once within a bounded time of real time (a reply normally takes ~3 s)."""

from __future__ import annotations

import re
import smtplib
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from gsm_served import MODEM, PHONE, PHONE2
from logger_world import (
    Cable,
    DataCall,
    World,
    cable,
    in_trace,
    registered,
    replies,
    start,
    wait_for,
)

#: How long a reply may take (real seconds): a few `com network delay`s and time limits.
REPLY_LIMIT = 30.0


def _answered_once(world: World, number: str, text: str, limit: float = REPLY_LIMIT) -> None:
    got = wait_for(lambda: replies(world, number, text), limit)
    time.sleep(1.0)  # a second copy would follow at once
    inbox = [m["text"] for m in world.phone.inbox(number)]
    assert got, f"no reply with {text!r} to {number} in {limit} s; inbox {inbox}"
    assert len(replies(world, number, text)) == 1, f"{text!r} answered more than once: {inbox}"


def _sms_while_initialising(tmp_path: Path) -> tuple[World, str]:
    """Symptom 1: the SMS goes in the same instant as ``write com close``."""
    world = start(tmp_path)
    line = Cable(world.cable_port)
    try:
        line.setup("write com device wavecom42")
        line.sock.sendall(b"write com close\r")
        world.phone.sms(PHONE2, MODEM, "##*#read i version##*#")
        assert line.sock.recv(64).endswith(b"OK\r\n")
    finally:
        line.close()
    reply = wait_for(lambda: replies(world, PHONE2, "2.10"), REPLY_LIMIT)
    return world, "answered" if reply else "no reply"


def test_an_sms_arriving_while_the_modem_is_initialised_is_answered(tmp_path: Path) -> None:
    """Three fresh worlds side by side (the race goes either way on the old driver): each
    answers, and the logger never echoes the modem's bytes back to it."""
    paths = [tmp_path / str(n) for n in range(3)]
    for path in paths:
        path.mkdir()
    with ThreadPoolExecutor(3) as pool:
        results = list(pool.map(_sms_while_initialising, paths))
    try:
        for world, outcome in results:
            assert outcome == "answered", world.trace()[:3000]
            _answered_once(world, PHONE2, "2.10", 1.0)
            # §7: bytes from the modem are never echoed back to it
            assert "logger>modem  +CMTI" not in world.trace()
            assert "logger>modem  \\r\\n" not in world.trace()
    finally:
        for world, _ in results:
            world.stop()


def test_a_data_call_after_coverage_lost_during_the_pop3_check_does_not_wedge(
    tmp_path: Path,
) -> None:
    """Symptom 2: coverage lost during the POP3 check after an e-mail, an SMS queued
    meanwhile, then a data call: the call is a command session, then SMS are answered."""
    world = start(tmp_path)
    try:
        # a command mail large enough that its RETR takes a few seconds at com speed
        body = "##*#read com speed##*#\r\n" + ("x" * 70 + "\r\n") * 50
        with smtplib.SMTP("127.0.0.1", world.smtp_port, timeout=10) as smtp:
            smtp.login("user@example.net", "secret")
            smtp.sendmail("user@example.net", ["logger@example.net"], f"Subject: cmd\r\n\r\n{body}")
        cable(
            world,
            "write com device wavecom42",
            "write address 1 type email write address 1 value user@example.net",
            f"write com network smtp address logger@example.net:secret@smtp.example.net:"
            f"{world.smtp_port}",
            f"write com network pop3 address logger@example.net:secret@pop3.example.net:"
            f"{world.pop3_port}",
            "write email send from logger@example.net",
            "write command 1 name/st/ write command 1 value/read i snumber/",
            "write message 1 address 1 write message 1 command 1",
            "write message 1 run 1",
        )
        assert in_trace(world, "RETR 1", 30.0), "the logger never checked its mail"
        time.sleep(1.0)  # the mail is coming, at com speed
        world.phone.coverage(MODEM, False)
        assert world.phone.sms(PHONE2, MODEM, "##*#read i version##*#")["queued"] is True
        time.sleep(2.0)
        world.phone.coverage(MODEM, True)
        call = DataCall(world, PHONE)
        try:
            assert call.connected(), f"the data call was not answered: {world.trace()[-3000:]}"
            call.send(b"read i snumber\r")
            assert call.expect(b"000001\r\nOK\r\n", 15.0), (call.received, world.trace()[-3000:])
            assert b"AT+" not in call.received  # no AT command in data mode
        finally:
            call.hang_up()
        _answered_once(world, PHONE2, "2.10")
        world.phone.sms(PHONE2, MODEM, "##*#read i snumber##*#")
        _answered_once(world, PHONE2, "000001")
    finally:
        world.stop()


#: An AT command line as the caller of a data call would see it (the driver's bytes in data mode).
AT_COMMAND = re.compile(rb"(?:^|[\r\n])AT|AT\+")


def _data_call_as_the_line_turns_modem(tmp_path: Path, lead: float) -> None:
    """Symptom 2 as the old driver showed it: a data call rings while the logger's com line
    still works as local (``write com device wavecom41`` given, ``write com close`` going,
    no AT sent yet). ``lead``: seconds from ``write com close`` to the call (< 0: the call
    first). The old driver answered (``ATA``, ``CONNECT 9600``), sent ``AT+CSQ`` straight into
    the data session and never answered its modem again."""
    world = start(tmp_path)
    try:
        line = Cable(world.cable_port)
        try:
            line.setup("write com device wavecom41")
            if lead < 0:
                call = DataCall(world, PHONE)
                time.sleep(-lead)
                line.sock.sendall(b"write com close\r")
            else:
                line.sock.sendall(b"write com close\r")
                time.sleep(lead)
                call = DataCall(world, PHONE)
            assert line.answer().endswith(b"OK\r\n")
        finally:
            line.close()
        if not call.connected():  # refusing a call that rang before the set-up is fair...
            call.hang_up()
            time.sleep(10.0)  # ...but the next one is a command session
            call = DataCall(world, PHONE)
            assert call.connected(), f"{call.reason}: {world.trace()[-3000:]}"
        try:
            call.send(b"read i version\r")
            answered = call.expect(b"2.10\r\nOK\r\n", 15.0)
            call.listen(1.0)  # anything the driver sends after the answer
            received = call.received
        finally:
            call.hang_up()
        where = f"lead {lead}: the caller got {received!r}; {world.trace()[-3000:]}"
        assert not AT_COMMAND.search(received), f"an AT command went into the data call, {where}"
        assert answered, f"no answer to read i version, {where}"
        assert received == b"2.10\r\nOK\r\n", where
        # the driver still talks to its modem: an SMS command is answered, once
        world.phone.sms(PHONE2, MODEM, "##*#read i version##*#")
        _answered_once(world, PHONE2, "2.10")
    finally:
        world.stop()


def test_a_data_call_ringing_as_the_line_turns_to_the_modem_is_a_command_session(
    tmp_path: Path,
) -> None:
    """Three fresh worlds side by side: the call rings just before, at and just after
    ``write com close`` (the logger's first AT); each is a clean command session and the
    SMS that follows is answered once."""
    leads = (-0.2, 0.0, 0.5)
    paths = [tmp_path / str(n) for n in range(len(leads))]
    for path in paths:
        path.mkdir()
    with ThreadPoolExecutor(len(leads)) as pool:
        runs = [
            pool.submit(_data_call_as_the_line_turns_modem, p, x)
            for p, x in zip(paths, leads, strict=True)
        ]
    failed = [f"{type(e).__name__}: {e}" for e in (run.exception() for run in runs) if e]
    assert not failed, "\n\n".join(failed)


def test_an_sms_arriving_during_a_data_call_is_answered_after_it(tmp_path: Path) -> None:
    """Symptom 3a: the modem holds the ``+CMTI`` until the call ends and sends it in the same
    read as ``NO CARRIER``."""
    world = start(tmp_path)
    try:
        cable(world, "write com device wavecom41")
        assert registered(world), "the logger's modem never registered"
        time.sleep(1.0)  # the logger's setup is over
        call = DataCall(world, PHONE)
        try:
            assert call.connected(), call.reason
            call.send(b"read i version\r")
            assert call.expect(b"2.10\r\nOK\r\n")
            world.phone.sms(PHONE2, MODEM, "##*#read com speed##*#")
            time.sleep(0.5)  # delivered to the modem, its notice held in data mode
        finally:
            call.hang_up()
        _answered_once(world, PHONE2, "9600")
    finally:
        world.stop()


def test_a_reply_refused_for_lost_coverage_is_sent_again(tmp_path: Path) -> None:
    """Symptom 3b: coverage goes between the registration check and ``AT+CMGS`` (during the
    ``com network delay`` after registration): ``+CMS ERROR: 331``; the reply goes later."""
    world = start(tmp_path)
    try:
        cable(world, "write com device wavecom41", "write com network delay 6")
        assert registered(world), "the logger's modem never registered"
        time.sleep(1.0)  # the logger's setup is over
        world.phone.coverage(MODEM, False)
        assert world.phone.sms(PHONE2, MODEM, "##*#read i snumber##*#")["queued"] is True
        time.sleep(1.0)
        world.phone.coverage(MODEM, True)  # registered again: the SMS comes, the delay runs
        assert in_trace(world, "AT+CMGD=1", 15.0), "the SMS was never read"
        time.sleep(1.5)
        world.phone.coverage(MODEM, False)  # gone before the delay is over
        time.sleep(6.0)
        world.phone.coverage(MODEM, True)
        _answered_once(world, PHONE2, "000001")
    finally:
        world.stop()
