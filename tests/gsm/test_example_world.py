"""The example world served whole (issue 12, docs/gsm.md walkthrough): the logger drives its
modem through AT bytes; a message goes out by SMS and by e-mail through the network and the
mail hub; an SMS command is answered by SMS. Real TCP, HTTP and POP3 on loopback."""

from __future__ import annotations

import json
import poplib
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

from gsm_served import MODEM, PHONE, PHONE2, example_text, free_port, serve

LOGIN = "secret"
ACCOUNT = f"logger@example.net:{LOGIN}"


def _start(
    tmp_path: Path, published: int | None = None
) -> tuple[subprocess.Popen[bytes], list[str]]:
    site = tmp_path / "gsm-site.toml"
    site.write_text(example_text(published if published is not None else free_port()))
    served = serve(site, tmp_path / "s", until="logger com line joined")
    return served.proc, served.lines


def _port(lines: list[str], prefix: str, index: int = 0) -> int:
    line = next(x for x in lines if x.startswith(prefix))
    return int(re.findall(r":(\d+)", line)[index])


def _api(lines: list[str], method: str, path: str, body: Any = None) -> Any:
    url = f"http://127.0.0.1:{_port(lines, 'gsm API')}{path}"
    data = None if body is None else json.dumps(body).encode()
    with urllib.request.urlopen(urllib.request.Request(url, data, method=method), timeout=10) as r:
        return json.loads(r.read())


def _ask(sock: socket.socket, command: str) -> bytes:
    sock.sendall(command.encode() + b"\r")
    data = b""
    while not data.endswith((b"OK\r\n", b"ERROR\r\n")):
        data += sock.recv(4096)
    return data


def _wait_sms(lines: list[str], number: str, text: str, limit: float = 60) -> list[str]:
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        got = [m["text"] for m in _api(lines, "GET", f"/sms?to={number}")]
        if any(text in m for m in got):
            return got
        time.sleep(0.5)
    raise AssertionError(f"no SMS with {text!r} to {number}: {got}")


def test_the_logger_sends_by_sms_and_email_and_answers_sms_commands(tmp_path: Path) -> None:
    proc, lines = _start(tmp_path)
    try:
        smtp, pop3 = _port(lines, "mail SMTP", 0), _port(lines, "mail SMTP", 1)
        with socket.create_connection(("127.0.0.1", _port(lines, "logger "))) as cable:
            cable.settimeout(10)
            for command in (
                "write command 1 name/status/ write command 1 value/read i snumber/",
                f"write address 1 type sms write address 1 value {PHONE}",
                "write address 2 type email write address 2 value user@example.net",
                f"write com network smtp address {ACCOUNT}@smtp.example.net:{smtp}",
                "write email send from logger@example.net",
                "write message 1 address 1,2 write message 1 command 1",
                "write com device wavecom41",
                "write com close",
            ):
                assert _ask(cable, command) == b"OK\r\n", command
            assert _ask(cable, "write message 1 run 1") == b"OK\r\n"
            assert _ask(cable, "write com close") == b"OK\r\n"
        # the message by SMS, through the modem and the network
        assert _wait_sms(lines, PHONE, "OK\r\n") == ["000001\r\nOK\r\n"]
        # ... and by e-mail, through the modem's GPRS socket to the real mail hub
        deadline = time.monotonic() + 60
        count = 0
        while time.monotonic() < deadline and count == 0:
            box = poplib.POP3("127.0.0.1", pop3, timeout=5)
            box.user("user@example.net")
            box.pass_(LOGIN)
            count = box.stat()[0]
            mail = b"\n".join(box.retr(1)[1]) if count else b""
            box.quit()
            time.sleep(0.5)
        assert count == 1 and b"From: logger@example.net" in mail
        assert b"000001\r\nOK" in mail.replace(b"\n", b"\r\n") or b"000001" in mail
        # an SMS command from a phone is answered by SMS
        _api(lines, "POST", "/sms", {"from": PHONE2, "to": MODEM, "text": "##*#read i version##*#"})
        assert _wait_sms(lines, PHONE2, "2.10") == ["2.10\r\nOK\r\n"]
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(15) == 0
    trace = (tmp_path / "s" / "gsm" / "modem.trace").read_text()
    assert "AT+CMGS=" in trace  # the logger drove its modem with AT commands


def test_download_over_a_data_call_and_over_the_gprs_port(tmp_path: Path) -> None:
    """Issue 13: the download works over every line the client knows, GSM included."""
    published = free_port()
    proc, lines = _start(tmp_path, published)
    try:
        with socket.create_connection(("127.0.0.1", _port(lines, "logger "))) as cable:
            cable.settimeout(10)
            for command in (
                *(f"write text/row {n}/" for n in range(5)),
                "write com device wavecom42",
            ):
                assert _ask(cable, command) == b"OK\r\n", command
            assert _ask(cable, "write com close") == b"OK\r\n"
        api = f"127.0.0.1:{_port(lines, 'gsm API')}"
        urls = {
            "call": f"gsm://{api}/{MODEM}?from={PHONE}",
            "gprs": f"tcp://127.0.0.1:{published}",
        }
        time.sleep(10)  # the logger first registers and attaches to GPRS through its modem
        for name, url in urls.items():
            out = tmp_path / f"{name}.csv"
            deadline = time.monotonic() + 60
            while True:
                done = subprocess.run(
                    [sys.executable, "-m", "sondalog", "logger", "download", url, "-o", str(out)],
                    capture_output=True, text=True, timeout=90,
                )  # fmt: skip
                if done.returncode == 0 or time.monotonic() > deadline:
                    break
                time.sleep(1)
            assert done.returncode == 0, (name, done.stderr)
            rows = out.read_text().splitlines()
            assert rows[0].startswith("logger,time,counter,type,channel,value")
            assert [r.split(",")[6] for r in rows[1:]] == [f"row {n}" for n in range(5)]
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(15) == 0
