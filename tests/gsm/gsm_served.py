"""Helpers for the tests of a served GSM world: the example site on free ports, started as
``python -m sondalog serve`` in a subprocess, an AT conversation over the modem's TCP line,
and the HTTP API through urllib."""

from __future__ import annotations

import json
import os
import re
import select
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gsm-site.toml"
MODEM = "+420600000001"
PHONE = "+420700000001"
PHONE2 = "+420700000002"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def example_text(published: int) -> str:
    """``examples/gsm-site.toml`` with every listener on a free port and the modem's port
    10001 published on ``published``."""
    text = EXAMPLE.read_text()
    text = re.sub(r'(listen|smtp|pop3|api) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    return text.replace('publish = { "10001" = 20001 }', f'publish = {{ "10001" = {published} }}')


def site_file(tmp_path: Path, pty: Path | None = None) -> tuple[Path, int]:
    """The example world on free ports; returns the file and the modem's published port."""
    published = free_port()
    text = example_text(published)
    link = pty if pty is not None else tmp_path / "modem-pty"
    # these tests are the modem's DTE themselves: no logger drives it, its lines are served
    text = text.replace('modem = "+420600000001"', "", 1)
    text = text.replace(
        '# pty = "/tmp/sondalog-gsm-modem"', f'pty = "{link}"\nlisten = "127.0.0.1:0"'
    )
    site = tmp_path / "gsm-site.toml"
    site.write_text(text)
    return site, published


@dataclass
class Served:
    proc: subprocess.Popen[bytes]
    lines: list[str] = field(default_factory=list)

    def port(self, prefix: str) -> int:
        line = next(x for x in self.lines if x.startswith(prefix))
        return int(re.findall(r":(\d+)", line)[0])

    @property
    def api(self) -> str:
        return f"http://127.0.0.1:{self.port('gsm API')}"

    @property
    def modem_port(self) -> int:
        return self.port("gsm modem +")

    @property
    def smtp_port(self) -> int:
        return self.port("mail SMTP")

    def request(self, method: str, path: str, body: Any = None) -> tuple[int, Any]:
        data = (
            None
            if body is None
            else (body if isinstance(body, bytes) else json.dumps(body).encode())
        )
        req = urllib.request.Request(self.api + path, data=data, method=method)
        try:
            with urllib.request.urlopen(req, timeout=10) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read())

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        assert self.proc.wait(15) == 0


def serve(
    site: Path,
    state: Path,
    *extra: str,
    until: str = "gsm modem pty",
    stderr: int = subprocess.PIPE,
) -> Served:
    """Start ``sondalog serve`` and wait until it announces a line starting with ``until``
    (by default the modem's pty: the GSM API and modem lines come before it)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(state), *extra],
        stdout=subprocess.PIPE,
        stderr=stderr,
    )
    served = Served(proc)
    assert proc.stdout is not None
    pending = b""
    while not any(x.startswith(until) for x in served.lines):
        ready, _, _ = select.select([proc.stdout], [], [], 30)
        chunk = os.read(proc.stdout.fileno(), 4096) if ready else b""
        if not chunk:
            proc.kill()
            _, err = proc.communicate()
            raise AssertionError(f"serve printed only {served.lines}: {(err or b'').decode()}")
        pending += chunk
        *lines, pending = pending.split(b"\n")
        served.lines += [line.decode().strip() for line in lines]
    return served


class AtLine:
    """A DTE on the modem's TCP line: send lines, wait for what comes back."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.buffer = b""

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def at(self, command: str, until: bytes = b"OK\r\n") -> bytes:
        """``command`` CR; everything up to and including ``until``."""
        self.send(command.encode("latin-1") + b"\r")
        return self.expect(until)

    def expect(self, pattern: bytes, timeout: float = 5.0) -> bytes:
        deadline = time.monotonic() + timeout
        while pattern not in self.buffer:
            left = deadline - time.monotonic()
            assert left > 0, f"no {pattern!r} in {self.buffer!r}"
            self.sock.settimeout(left)
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                continue
            assert data, f"line closed; got {self.buffer!r}"
            self.buffer += data
        end = self.buffer.index(pattern) + len(pattern)
        out, self.buffer = self.buffer[:end], self.buffer[end:]
        return out

    def close(self) -> None:
        self.sock.close()
