"""Throughput of the pure GSM cores (no I/O): AT commands, SMS end to end, PDUs, data calls.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_gsm.py [--seconds S]``.

- AT+CSQ: one command line in, its answer out (modem core alone).
- SMS text mode: ``AT+CMGS`` + text + Ctrl-Z from the modem to a phone through the network's
  SMS centre (modem, network and their composition).
- SMS delivered: a phone's SMS to the modem, stored, ``+CMTI``, ``AT+CMGR``, ``AT+CMGD``.
- PDU: encode + decode of a 160-character SMS-DELIVER.
- data call: bytes from the DTE to the far end in data mode, 1 KiB chunks.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

from sondalog.gsm import events as ev
from sondalog.gsm import pdu
from sondalog.gsm.modem import Modem
from sondalog.gsm.system import GsmSystem

MODEM = "+420600000001"
PHONE = "+420700000001"


def rate(name: str, unit: str, fn: Callable[[], int], seconds: float) -> None:
    done = 0
    start = time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        done += fn()
    elapsed = time.perf_counter() - start
    print(f"{name:<28} {done / elapsed:>14,.0f} {unit}/s")


def system() -> tuple[GsmSystem, Modem]:
    s = GsmSystem()
    s.network.add_phone(PHONE)
    m = Modem()
    s.add_modem(MODEM, m, 0.0)
    s.modem_input(MODEM, b"ATE0;+CMGF=1\r", 0.0)
    return s, m


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=1.0)
    seconds = parser.parse_args().seconds

    s, m = system()
    rate("AT+CSQ", "commands", lambda: (m.receive(b"AT+CSQ\r", 0.0), 1)[1], seconds)

    s, m = system()
    line = f'AT+CMGS="{PHONE}"\r'.encode() + b"read com speed\r\n9600\r\nOK\r\n\x1a"

    def send_sms() -> int:
        s.modem_input(MODEM, line, 0.0)
        return 1

    rate("SMS modem -> phone", "SMS", send_sms, seconds)
    print(f"{'':<28} {len(s.network.delivered(PHONE)):>14,} SMS at the phone")

    s, m = system()

    def receive_sms() -> int:
        s.network_call(s.network.phone_sms(PHONE, MODEM, "##*#read date##*#", 0.0), 0.0)
        s.modem_input(MODEM, b"AT+CMGR=1\rAT+CMGD=1\r", 0.0)
        return 1

    rate("SMS phone -> modem (read)", "SMS", receive_sms, seconds)

    def pdu_round() -> int:
        raw = pdu.encode_deliver(PHONE, "x" * 160, 1_764_464_400)
        pdu.decode_deliver(raw)
        return 1

    rate("PDU encode+decode 160 ch", "PDUs", pdu_round, seconds)

    s, m = system()
    _, items = s.network.phone_call(PHONE, MODEM, ev.DATA, 0.0)
    s.network_call(items, 0.0)
    s.modem_input(MODEM, b"ATA\r", 0.0)
    chunk = b"0123456789abcdef" * 64

    def data() -> int:
        s.modem_input(MODEM, chunk, 0.0)
        return len(chunk)

    rate("data call DTE -> far end", "bytes", data, seconds)


if __name__ == "__main__":
    main()
