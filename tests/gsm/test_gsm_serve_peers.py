"""Real peers of the served GSM world: Debian's gammu on the SERVED modem's pty, the
``sondalog phone`` commands and ``sondalog term gsm://...`` over a data call."""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from gsm_served import MODEM, PHONE, PHONE2, AtLine, Served, serve, site_file

GAMMU = shutil.which("gammu")


@pytest.fixture
def world(tmp_path: Path) -> Iterator[Served]:
    site, _ = site_file(tmp_path)
    served = serve(site, tmp_path / "state")
    try:
        yield served
    finally:
        if served.proc.poll() is None:
            served.stop()


def sondalog(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "sondalog", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.skipif(GAMMU is None, reason="Debian's gammu (/usr/bin/gammu) is not installed")
def test_gammu_on_the_served_modem_pty(world: Served, tmp_path: Path) -> None:
    assert GAMMU is not None
    pty = next(x for x in world.lines if x.startswith("gsm modem pty")).split()[3]
    rc = tmp_path / "gammurc"
    rc.write_text(f"[gammu]\ndevice = {pty}\nconnection = at\n")

    def gammu(*args: str) -> str:
        result = subprocess.run(
            [GAMMU, "-c", str(rc), *args],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert result.returncode == 0, result.stdout + result.stderr
        return result.stdout

    assert "356938035643809" in gammu("--identify")
    assert "message reference=1" in gammu("sendsms", "TEXT", PHONE2, "-text", "from gammu")
    inbox = world.request("GET", f"/sms?to={PHONE2}")[1]
    assert [(m["from"], m["text"]) for m in inbox] == [(MODEM, "from gammu")]
    status, _ = world.request("POST", "/sms", {"from": PHONE, "to": MODEM, "text": "Kč 5 €"})
    assert status == 201
    listing = gammu("getallsms")
    assert f'Remote number        : "{PHONE}"' in listing and "Kč 5 €" in listing


def test_phone_commands(world: Served) -> None:
    api = ("--api", world.api)
    sent = sondalog("phone", *api, "sms", PHONE, MODEM, "##*#read com speed##*#")
    assert sent.returncode == 0, sent.stderr
    assert sent.stdout == "SMS 1 delivered\n"
    inbox = sondalog("phone", *api, "inbox", MODEM)
    assert inbox.returncode == 0 and f"from {PHONE}\n  ##*#read com speed##*#\n" in inbox.stdout
    empty = sondalog("phone", *api, "inbox", PHONE2)  # an empty inbox says so
    assert (empty.returncode, empty.stdout) == (0, f"no SMS delivered to {PHONE2}\n")
    waiting = sondalog("phone", *api, "inbox", "--queued", PHONE2)
    assert waiting.stdout == f"no SMS waiting at the SMS centre for {PHONE2}\n"
    assert sondalog("phone", *api, "inbox", "--json", PHONE2).stdout == "[]\n"
    wrong = sondalog("phone", *api, "sms", PHONE, "+420111", "x")
    assert wrong.returncode == 2 and "+420111 is not a modem or phone" in wrong.stderr
    voice = sondalog("phone", *api, "call", PHONE, MODEM, "--voice")
    assert voice.returncode == 0 and voice.stdout.endswith(": ringing\n")
    busy = sondalog("phone", *api, "call", PHONE2, MODEM, "--data")
    assert busy.returncode == 0 and busy.stdout.endswith("ended (busy)\n")
    gone = sondalog("phone", "--api", "http://127.0.0.1:9", "inbox", MODEM)
    assert gone.returncode == 1 and "cannot reach the network API" in gone.stderr


def test_term_over_a_data_call(world: Served) -> None:
    """``sondalog term gsm://...`` places a data call; the DTE (here the test, as the logger
    would) answers it and answers the command that comes through."""
    dte = AtLine(world.modem_port)
    dte.at("ATE0")
    dte.at("AT+CRC=1;+CLIP=1")
    errors: list[BaseException] = []

    def logger_side() -> None:
        try:
            dte.expect(b"+CRING: REL ASYNC", timeout=20)
            dte.expect(f'+CLIP: "{PHONE}",145'.encode())
            dte.at("ATA", b"CONNECT 9600\r\n")
            dte.expect(b"read com speed\r", timeout=10)
            dte.send(b"read com speed\r\n9600\r\nOK\r\n")
        except BaseException as exc:  # reported by the test below
            errors.append(exc)

    thread = threading.Thread(target=logger_side, daemon=True)
    thread.start()
    netloc = world.api.removeprefix("http://")
    url = f"gsm://{netloc}/{MODEM}?from={PHONE}"
    result = sondalog("term", url, stdin="read com speed\n")
    thread.join(10)
    dte.close()
    assert errors == []
    assert result.returncode == 0, result.stderr
    assert "9600" in result.stdout
    calls = world.request("GET", "/calls")[1]
    assert calls[-1]["kind"] == "data" and calls[-1]["state"] == "ended"
    unknown = sondalog("term", f"gsm://{netloc}/+420111?from={PHONE}", stdin="x\n")
    assert unknown.returncode != 0 and "+420111 is not a modem or phone" in unknown.stderr
