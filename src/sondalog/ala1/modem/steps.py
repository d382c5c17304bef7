"""Steps the driver's jobs share (:mod:`~sondalog.ala1.modem.jobs` and
:mod:`~sondalog.ala1.modem.mailjobs`): the radio on or off, waiting for registration and
``com network delay`` (§6.11.6.5), running a command line as the logger answers it. Each is a
generator of :mod:`~sondalog.ala1.modem.atio` requests, like the jobs; ``d`` is the
:class:`~sondalog.ala1.modem.host.Driver`."""

from __future__ import annotations

from collections.abc import Generator

from sondalog.ala1.modem.atio import Job, Request, Sleep, at
from sondalog.ala1.modem.host import Driver

#: How long the driver waits for registration before a sending fails (no coverage).
REGISTRATION_TIMEOUT = 60.0
REGISTRATION_POLL = 2.0


def radio(d: Driver, on: bool) -> Job:
    if d.radio != on:
        yield from at(f"AT+CFUN={1 if on else 0}")
        d.radio = on
        if not on:
            d.registered_since = None
            d.gprs = d.listening = False
        else:
            d.listing_due = True  # SMS the centre held while the radio was off


def registered(d: Driver) -> Generator[Request, object, bool]:
    """Radio on, registered, and ``com network delay`` passed since registration (§6.11.6.5)."""
    yield from radio(d, True)
    end = d.now + REGISTRATION_TIMEOUT
    while True:
        reply = yield from at("AT+CREG?")
        line = reply.info("+CREG:") or ""
        stat = line.split(",")[1].strip() if line.count(",") >= 1 else ""
        if stat in ("1", "5"):
            if d.registered_since is None:
                d.registered_since = d.now
                d.network_back()
            delay = float(d.host.setting("com network delay") or 0)
            wait = d.registered_since + delay - d.now
            if wait > 0:
                yield Sleep(wait)
            return True
        d.registered_since = None
        if reply.final == "" or d.now >= end:
            return False
        yield Sleep(REGISTRATION_POLL)


def execute(d: Driver, text: str) -> Generator[Request, object, str]:
    """The command's answer exactly as a line carries it; ``pause``/sensor waits are slept."""
    paused = False
    for _ in range(1000):
        answer = d.host.execute(text, d.now, paused)
        if isinstance(answer, bytes):
            return answer.decode("latin-1")
        yield Sleep(answer)
        paused = True
    return ""
