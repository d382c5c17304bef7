"""The real peer: Debian's gammu drives the simulated modem over a real pty (gsm.md §2,
recipes.md §5): it identifies the modem, sends an SMS in PDU mode that arrives at the network's
SMS centre, and reads the SMS stored on the modem."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from modem_pty import ModemPty

from sondalog.gsm.system import GsmSystem

GAMMU = shutil.which("gammu")
PHONE = "+420700000001"

pytestmark = pytest.mark.skipif(GAMMU is None, reason="Debian's gammu is not installed")


@pytest.fixture
def modem(tmp_path: Path) -> Iterator[tuple[ModemPty, Path]]:
    with ModemPty() as mp:
        mp.call(lambda s, now: s.network.add_phone(PHONE))
        rc = tmp_path / "gammurc"
        rc.write_text(
            f"[gammu]\ndevice = {mp.path}\nconnection = at\n"
            f"logformat = textall\nlogfile = {tmp_path / 'gammu.log'}\n"
        )
        yield mp, rc
    assert mp.errors == []


def gammu(rc: Path, *args: str) -> subprocess.CompletedProcess[str]:
    assert GAMMU is not None
    return subprocess.run(
        [GAMMU, "-c", str(rc), *args],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=60,
    )


def test_gammu_identifies_the_modem(modem: tuple[ModemPty, Path]) -> None:
    mp, rc = modem
    result = gammu(rc, "--identify")
    assert result.returncode == 0, result.stderr
    assert "Wavecom" in result.stdout
    assert "356938035643809" in result.stdout  # IMEI
    assert "230011234567890" in result.stdout  # SIM IMSI
    assert b"AT+CGSN\r" in mp.rx() and b"AT+CFUN=1\r" in mp.rx()


def test_gammu_sends_sms_in_pdu_mode(modem: tuple[ModemPty, Path]) -> None:
    mp, rc = modem
    result = gammu(rc, "sendsms", "TEXT", PHONE, "-text", "hi")
    assert result.returncode == 0, result.stderr
    assert "message reference=1" in result.stdout
    assert b"AT+CMGF=0\r" in mp.rx() and b"AT+CMGS=16\r" in mp.rx()
    delivered = mp.call(lambda s, now: s.network.delivered(PHONE))
    assert [(d.sender, d.text) for d in delivered] == [("+420600000001", "hi")]


def test_gammu_reads_stored_sms(modem: tuple[ModemPty, Path]) -> None:
    mp, rc = modem

    def inject(s: GsmSystem, now: float) -> object:
        s.network_call(s.network.phone_sms(PHONE, mp.number, "##*#read com speed##*#", now), now)
        return s.network_call(s.network.phone_sms(PHONE, mp.number, "Kč 5 €", now), now)

    mp.call(inject)
    result = gammu(rc, "getallsms")
    assert result.returncode == 0, result.stderr
    assert result.stdout.count(f'Remote number        : "{PHONE}"') == 2
    assert "##*#read com speed##*#" in result.stdout
    assert "Kč 5 €" in result.stdout  # UCS2 in PDU mode
    assert "2 SMS parts in 2 SMS sequences" in result.stdout


def test_gammu_sends_a_long_unicode_sms_in_parts(modem: tuple[ModemPty, Path]) -> None:
    mp, rc = modem
    text = "Měření " + "x" * 80  # 87 UCS2 characters: two parts with a concatenation header
    result = gammu(rc, "sendsms", "TEXT", PHONE, "-unicode", "-len", str(len(text)), "-text", text)
    assert result.returncode == 0, result.stderr
    delivered = mp.call(lambda s, now: s.network.delivered(PHONE))
    assert "".join(d.text for d in delivered) == text
    assert [(d.alphabet, d.concat.seq, d.concat.total) for d in delivered if d.concat] == [
        ("ucs2", 1, 2),
        ("ucs2", 2, 2),
    ]


def test_gammu_reads_network_info(modem: tuple[ModemPty, Path]) -> None:
    # (gammu getussd *101# works too, but gammu then idles 10 s before it exits: the exact
    # request it sends, in UCS2, is a unit test in test_modem_at.py)
    mp, rc = modem
    info = gammu(rc, "networkinfo")
    assert info.returncode == 0, info.stderr
    assert "Network state        : home network" in info.stdout
    assert "LAC 0FA1, CID 2B3C" in info.stdout
    assert 'Name in phone        : "SONDALOG GSM"' in info.stdout
    assert b"AT+CREG=2\r" in mp.rx() and b"AT+COPS?\r" in mp.rx()
