"""The served GSM world (issue 12: the network runtime): ``sondalog serve`` with a ``[gsm]``
table runs the network, its modems on real TCP lines and ptys, the IP gateway on real TCP and
the HTTP API; state survives a restart."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from gsm_served import MODEM, PHONE, PHONE2, AtLine, Served, serve, site_file


@pytest.fixture
def world(tmp_path: Path) -> Iterator[tuple[Served, int]]:
    site, published = site_file(tmp_path)
    served = serve(site, tmp_path / "state")
    try:
        yield served, published
    finally:
        if served.proc.poll() is None:
            served.stop()


def test_sms_both_ways_between_the_api_and_the_modem_line(world: tuple[Served, int]) -> None:
    served, _ = world
    dte = AtLine(served.modem_port)
    try:
        dte.at("ATE0")
        dte.at("AT+CMGF=1;+CMEE=1")
        status, body = served.request("POST", "/sms", {"from": PHONE, "to": MODEM, "text": "hi"})
        assert status == 201 and body["queued"] is False
        assert b'+CMTI: "SM",1' in dte.expect(b'\r\n+CMTI: "SM",1\r\n')
        answer = dte.at("AT+CMGR=1")
        assert f'"REC UNREAD","{PHONE}"'.encode() in answer and b"\r\nhi\r\n" in answer
        dte.send(f'AT+CMGS="{PHONE2}"\r'.encode())
        dte.expect(b"> ")
        dte.send(b"read com speed\x1a")
        assert b"+CMGS: 1" in dte.expect(b"OK\r\n")
        status, inbox = served.request("GET", f"/sms?to={PHONE2}")
        assert status == 200
        assert [(m["from"], m["to"], m["text"]) for m in inbox] == [
            (MODEM, PHONE2, "read com speed")
        ]
        assert inbox[0]["time"].endswith("Z")
        # the logger's [logger.gsm] models drive the modem's signal and credit
        assert b"Your credit is 250.00 CZK" in dte.at('AT+CUSD=1,"*101#",15', b"15\r\n")
        rssi = int(dte.at("AT+CSQ").split(b"+CSQ: ")[1].split(b",")[0])
        assert 14 <= rssi <= 22  # sine around 18, amplitude 4
    finally:
        dte.close()
    trace = (served_state(served) / "gsm" / "modem.trace").read_text()
    assert "logger>modem  AT+CMGF=1;+CMEE=1\\r" in trace
    assert "modem>logger  \\r\\n+CMGS: 1\\r\\n\\r\\nOK\\r\\n" in trace


def served_state(served: Served) -> Path:
    args = served.proc.args
    assert isinstance(args, list)
    return Path(args[args.index("--state") + 1])


def test_bad_requests_get_400_and_unknown_numbers_404(world: tuple[Served, int]) -> None:
    served, _ = world
    assert served.request("POST", "/sms", b"not json")[0] == 400
    assert served.request("POST", "/sms", [1, 2])[0] == 400
    assert served.request("POST", "/sms", {"from": PHONE, "to": MODEM})[0] == 400
    assert served.request("POST", "/sms", {"from": PHONE, "to": MODEM, "text": 5})[0] == 400
    assert served.request("POST", "/sms", {"from": PHONE, "to": "abc", "text": "x"})[0] == 400
    status, body = served.request("POST", "/sms", {"from": PHONE, "to": "+4209", "text": "x"})
    assert status == 404 and "+4209" in body["error"]
    assert served.request("POST", "/sms", {"from": MODEM, "to": PHONE, "text": "x"})[0] == 404
    assert served.request("GET", "/sms")[0] == 400
    assert served.request("POST", "/call", {"from": PHONE, "to": MODEM, "kind": "fax"})[0] == 400
    assert served.request("POST", "/coverage", {"number": MODEM, "covered": "no"})[0] == 400
    assert served.request("DELETE", "/calls/77")[0] == 404
    assert served.request("GET", "/health") == (200, {"ok": True, "subscribers": 3})
    # nothing was stored by the refused requests
    assert served.request("GET", f"/sms?to={MODEM}") == (200, [])


def test_out_of_coverage_queues_sms_across_a_restart(tmp_path: Path) -> None:
    site, _ = site_file(tmp_path)
    served = serve(site, tmp_path / "state")
    try:
        assert served.request("POST", "/coverage", {"number": MODEM, "covered": False})[0] == 200
        status, body = served.request("POST", "/sms", {"from": PHONE, "to": MODEM, "text": "one"})
        assert status == 201 and body["queued"] is True
        queued = served.request("GET", f"/sms?to={MODEM}&queued=1")[1]
        assert [m["text"] for m in queued] == ["one"]
    finally:
        served.stop()
    served = serve(site, tmp_path / "state", "--trace", str(tmp_path / "cli.trace"))
    try:
        subscribers = {s["number"]: s for s in served.request("GET", "/subscribers")[1]}
        assert subscribers[MODEM]["registered"] is False and subscribers[MODEM]["queued"] == 1
        assert served.request("GET", f"/sms?to={MODEM}")[1] == []
        dte = AtLine(served.modem_port)
        try:
            dte.at("ATE0")
            assert b"+CREG: 0,2" in dte.at("AT+CREG?")  # searching: radio on, no coverage
            served.request("POST", "/coverage", {"number": MODEM, "covered": True})
            dte.expect(b'+CMTI: "SM",1')
        finally:
            dte.close()
        assert [m["text"] for m in served.request("GET", f"/sms?to={MODEM}")[1]] == ["one"]
        assert served.request("GET", f"/sms?to={MODEM}&queued=1")[1] == []
    finally:
        served.stop()
    trace = (tmp_path / "cli.trace").read_text()  # --trace FILE: the logger's modem's line
    assert "logger>modem  AT+CREG?\\r" in trace and "modem>logger  \\r\\n+CMTI:" in trace


def test_gprs_reaches_the_mail_hub_and_the_published_port(world: tuple[Served, int]) -> None:
    served, published = world
    dte = AtLine(served.modem_port)
    try:
        dte.at("ATE0")
        for command in ("AT+WIPCFG=1", "AT+WIPBR=1,6", 'AT+WIPBR=2,6,11,"internet"'):
            dte.at(command)
        dte.at("AT+WIPBR=4,6,0")
        # a WIPsoft client socket to smtp.example.net: the real SMTP server of the mail hub
        dte.at(f'AT+WIPCREATE=2,1,"smtp.example.net",{served.smtp_port}')
        dte.expect(b"+WIPREADY: 2,1\r\n")
        dte.expect(b"+WIPDATA: 2,1,")  # the server's greeting waits for AT+WIPDATA
        dte.at("AT+WIPDATA=2,1,1", b"CONNECT\r\n")
        assert dte.expect(b"\r\n").startswith(b"220 ")
        dte.send(b"EHLO logger\r\n")
        assert b"250-" in dte.expect(b"250 HELP\r\n")
        # port 10001 of the modem is published only while the modem listens on it
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", published), timeout=1)
        dte.send(b"QUIT\r\n")
        dte.expect(b"221")
        dte.expect(b"SHUTDOWN")  # the server closed the connection
        time.sleep(1.1)  # the +++ guard time
        dte.send(b"+++")
        dte.expect(b"OK\r\n", timeout=3)
        dte.at("AT+WIPCREATE=3,1,10001,2,2")
        deadline = time.monotonic() + 5
        while True:
            try:
                peer = socket.create_connection(("127.0.0.1", published), timeout=5)
                break
            except ConnectionRefusedError:
                assert time.monotonic() < deadline
                time.sleep(0.05)
        with peer:
            dte.expect(b"+WIPACCEPT: 1,2\r\n")
            dte.at("AT+WIPDATA=2,2,1", b"CONNECT\r\n")
            peer.sendall(b"read com speed\r")
            assert dte.expect(b"read com speed\r").endswith(b"read com speed\r")
            dte.send(b"9600\r\nOK\r\n")
            got = b""
            while not got.endswith(b"OK\r\n"):
                got += peer.recv(100)
            assert got == b"9600\r\nOK\r\n"
    finally:
        dte.close()


def test_serve_refuses_a_bad_gsm_table(tmp_path: Path) -> None:
    site, _ = site_file(tmp_path)
    site.write_text(site.read_text().replace('number = "+420700000002"', 'number = "nope"'))
    result = subprocess.run(
        [sys.executable, "-m", "sondalog", "serve", str(site)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert result.returncode == 2
    assert "gsm.phone[1].number" in result.stderr and "not an E.164 number" in result.stderr
