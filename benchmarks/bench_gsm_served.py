"""The served GSM world: AT round trips on a modem's TCP line, SMS through the HTTP API, and
data through the GPRS gateway (``sondalog serve examples/gsm-site.toml`` on free ports).

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_gsm_served.py [--seconds S]``.

- AT round trip: ``AT+CSQ`` CR on the modem's TCP line until its ``OK`` (one at a time).
- API SMS: ``POST /sms`` phone -> phone through urllib (one connection per request, as
  ``sondalog phone`` does), then one ``GET /sms`` to check all arrived.
- API SMS to the modem with its line attached: ``POST /sms`` until ``+CMTI`` is on the line,
  then ``AT+CMGD`` (the store would fill).
- GPRS echo: bytes through ``AT+WIPDATA`` continuous mode to a real TCP echo server and back
  (4 KiB chunks), in MB/s.
"""

from __future__ import annotations

import argparse
import json
import re
import select
import socket
import socketserver
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "gsm-site.toml"
MODEM = "+420600000001"
PHONE = "+420700000001"
PHONE2 = "+420700000002"


class Echo(socketserver.BaseRequestHandler):
    def handle(self) -> None:
        while data := self.request.recv(65536):
            self.request.sendall(data)


def start(tmp: Path, echo_port: int) -> tuple[subprocess.Popen[bytes], dict[str, int]]:
    text = EXAMPLE.read_text()
    text = re.sub(r'(listen|smtp|pop3|api) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    text = text.replace('pty = "/tmp/sondalog-gsm-modem"', f'pty = "{tmp / "pty"}"')
    text = text.replace('"pop3.example.net" = "127.0.0.1"', '"echo.example.net" = "127.0.0.1"')
    text = text.replace('trace = "modem.trace"', "")
    site = tmp / "site.toml"
    site.write_text(text)
    cmd = [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(tmp / "s")]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE)
    assert proc.stdout is not None
    out = b""
    while b"gsm modem pty" not in out:
        select.select([proc.stdout], [], [], 30)
        out += proc.stdout.read1(4096)
    ports = {}
    for line in out.decode().splitlines():
        if line.startswith("gsm API"):
            ports["api"] = int(line.rsplit(":", 1)[1])
        if line.startswith("gsm modem +"):
            ports["modem"] = int(line.rsplit(":", 1)[1])
    return proc, ports


class Line:
    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port))
        self.buf = b""

    def until(self, pattern: bytes) -> bytes:
        while pattern not in self.buf:
            self.buf += self.sock.recv(65536)
        end = self.buf.index(pattern) + len(pattern)
        out, self.buf = self.buf[:end], self.buf[end:]
        return out

    def at(self, command: bytes, until: bytes = b"OK\r\n") -> bytes:
        self.sock.sendall(command + b"\r")
        return self.until(until)


def post(api: str, body: dict[str, str]) -> None:
    req = urllib.request.Request(api + "/sms", json.dumps(body).encode(), method="POST")
    with urllib.request.urlopen(req) as response:
        response.read()


def timed(name: str, unit: str, seconds: float, step: object) -> None:
    assert callable(step)
    done, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        done += step()
    elapsed = time.perf_counter() - t0
    print(f"{name:<40} {done / elapsed:>10.0f} {unit}/s")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=2.0)
    seconds = parser.parse_args().seconds
    echo = socketserver.ThreadingTCPServer(("127.0.0.1", 0), Echo)
    threading.Thread(target=echo.serve_forever, daemon=True).start()
    with tempfile.TemporaryDirectory() as tmp:
        proc, ports = start(Path(tmp), echo.server_address[1])
        try:
            api = f"http://127.0.0.1:{ports['api']}"
            line = Line(ports["modem"])
            line.at(b"ATE0")
            timed(
                "AT+CSQ round trip (TCP line)",
                "commands",
                seconds,
                lambda: line.at(b"AT+CSQ") and 1,
            )
            timed(
                "API POST /sms phone -> phone",
                "SMS",
                seconds,
                lambda: post(api, {"from": PHONE, "to": PHONE2, "text": "x"}) or 1,
            )

            def to_modem() -> int:
                post(api, {"from": PHONE, "to": MODEM, "text": "y"})
                index = line.until(b"\r\n").strip() or line.until(b"\r\n").strip()
                line.at(b"AT+CMGD=" + index.rsplit(b",", 1)[1])
                return 1

            line.at(b"AT+CMGF=1;+CNMI=2,1")
            timed("API SMS -> modem line (+CMTI, CMGD)", "SMS", seconds, to_modem)
            for command in (b"AT+WIPCFG=1", b"AT+WIPBR=1,6", b"AT+WIPBR=4,6,0"):
                line.at(command)
            line.at(b'AT+WIPCREATE=2,1,"echo.example.net",%d' % echo.server_address[1])
            line.until(b"+WIPREADY: 2,1\r\n")
            line.at(b"AT+WIPDATA=2,1,1", b"CONNECT\r\n")
            chunk = b"z" * 4096

            def echo_step() -> int:
                line.sock.sendall(chunk)
                got = 0
                while got < len(chunk):
                    got += len(line.sock.recv(65536))
                return len(chunk)

            done, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                done += echo_step()
            rate = done / (time.perf_counter() - t0) / 1e6
            print(f"{'GPRS echo through the gateway (4 KiB)':<40} {rate:>10.2f} MB/s")
        finally:
            proc.terminate()
            proc.wait(10)
            echo.shutdown()


if __name__ == "__main__":
    main()
