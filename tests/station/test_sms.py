"""``logger config apply --via sms`` (issue 22): the settings as SMS commands through the
served GSM network, each answer checked, split to fit 160 GSM-7 septets."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from station_helpers import MODEM, PHONE, explain_text, free_port, port_of, serve_gsm_world

from sondalog.client.phone import PhoneApi
from sondalog.client.station_file import read_station
from sondalog.client.station_sms import apply_by_sms, pack
from sondalog.config import ConfigError, loads
from sondalog.protocol.gsm7 import septet_length

NAMES = ["Hladina[cm]", "Teplota[C]", "Srazky[mm]", "Vitr[m/s]", "Tlak[hPa]", "Vlhkost[%]"]
FILE = "".join(
    f'[channel.{n}]\nname = "{name}"\nsampling_period = "00{n:02d}00"\n'
    for n, name in enumerate(NAMES, start=1)
)


def test_writes_are_packed_into_sms_of_160_septets() -> None:
    station = read_station(loads('[sms]\ncommand_boundary = "#!#"\n' + FILE))
    groups = pack(station, "#!#", "")
    texts = ["##*#" + " ".join(w for _, w in g) + "##*#" for g in groups]
    assert [len(g) for g in groups] == [3, 3, 3, 3, 1]  # one command line of 120 characters each
    assert all(septet_length(t) <= 160 and len(t) <= 128 for t in texts)
    assert septet_length(texts[0]) > len(texts[0])  # '[' and ']' take two septets each
    assert groups[-1] == [("sms command boundary", "write sms command boundary/#!#/")]
    with pytest.raises(ConfigError, match=r"<config>:2: identity.name: an SMS cannot carry"):
        pack(read_station(loads('[identity]\nname = "a`b"\n')), "##*#", "")


def _ask(cable: socket.socket, command: str) -> bytes:
    cable.sendall(command.encode() + b"\r")
    data = b""
    while not data.endswith((b"OK\r\n", b"ERROR\r\n")):
        data += cable.recv(4096)
    return data


def test_apply_by_sms_through_the_served_network(tmp_path: Path) -> None:
    proc, lines = serve_gsm_world(tmp_path, free_port())
    try:
        cable = socket.create_connection(("127.0.0.1", port_of(lines, "logger ")), timeout=10)
        for command in ("write channel value", "write com device wavecom41", "write com close"):
            assert _ask(cable, command) == b"OK\r\n"
        url = f"gsm://127.0.0.1:{port_of(lines, 'gsm API')}/{MODEM}?from={PHONE}"
        (tmp_path / "s.toml").write_text(FILE)
        done = subprocess.run(
            [sys.executable, "-m", "sondalog", "logger", "config", "apply", url, "s.toml",
             "--via", "sms", "--yes"],
            capture_output=True, text=True, timeout=400, cwd=tmp_path, check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stdout + done.stderr
        assert done.stdout.startswith("SMS 1/4: write channel 1 name/Hladina[cm]/")
        assert done.stdout.endswith("12 writes sent by SMS, every answer OK\n")
        answer = _ask(cable, "read channel 6 name read channel 6 sampling period")
        assert answer == b"Vlhkost[%]\r\n000600\r\nOK\r\n"
        (tmp_path / "bad.toml").write_text('[record]\ntype = "LINEAR"\n')
        done = subprocess.run(
            [sys.executable, "-m", "sondalog", "logger", "config", "apply", url, "bad.toml",
             "--via", "sms", "--yes"],
            capture_output=True, text=True, timeout=400, cwd=tmp_path, check=False,
        )  # fmt: skip
        assert done.returncode == 2
        assert "the logger answered 'write record type linear\\r\\nERROR'" in done.stderr
        assert "record type only while the record is empty" in done.stderr
        api = PhoneApi(f"http://127.0.0.1:{port_of(lines, 'gsm API')}")
        api.coverage(MODEM, False)  # the logger out of coverage: no answer comes
        started = time.monotonic()
        outcome = apply_by_sms(url, read_station(loads(FILE)), explain_text, reply_timeout=3)
        assert outcome.error is not None and outcome.error.startswith("no answer within 3 s")
        assert time.monotonic() - started < 10  # it gives up, and says what was not sent
        assert outcome.sent == [] and len(outcome.not_sent) == 12
        cable.close()
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(15)
