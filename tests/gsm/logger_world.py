"""Helpers for tests of the served example world *with its logger* (issue 20): the example
site on free ports with the logger driving its modem, started as ``python -m sondalog serve``
in a subprocess; cable sessions on the logger's TCP line; data calls through the API's bridge;
the phones' inboxes; the modem line's trace read while the world runs."""

from __future__ import annotations

import re
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gsm_served import MODEM, Served, example_text, free_port, serve

from sondalog.client.phone import PhoneApi


def logger_site(tmp_path: Path) -> Path:
    """The example world on free ports, its logger driving its modem (as shipped)."""
    site = tmp_path / "gsm-site.toml"
    site.write_text(example_text(free_port()))
    return site


@dataclass
class World:
    served: Served
    state: Path

    @property
    def phone(self) -> PhoneApi:
        return PhoneApi(self.served.api)

    @property
    def cable_port(self) -> int:
        return self.served.port("logger ")

    @property
    def smtp_port(self) -> int:
        return self.served.port("mail SMTP")

    @property
    def pop3_port(self) -> int:
        line = next(x for x in self.served.lines if x.startswith("mail SMTP"))
        return int(re.findall(r":(\d+)", line)[1])

    def trace(self) -> str:
        path = self.state / "gsm" / "modem.trace"
        return path.read_text() if path.exists() else ""

    def stop(self) -> None:
        if self.served.proc.poll() is None:
            self.served.stop()


def start(tmp_path: Path, *extra: str) -> World:
    """``sondalog serve`` on :func:`logger_site`; returns once the logger's com line joined."""
    state = tmp_path / "state"
    served = serve(logger_site(tmp_path), state, *extra, until="logger com line joined")
    return World(served, state)


class Cable:
    """The logger's cable line (TCP): one command line at a time, its answer."""

    def __init__(self, port: int) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)

    def ask(self, command: str) -> bytes:
        self.sock.sendall(command.encode() + b"\r")
        return self.answer()

    def answer(self) -> bytes:
        """The answer of a command line already sent (up to its ``OK``/``ERROR``)."""
        data = b""
        while not data.endswith((b"OK\r\n", b"ERROR\r\n")):
            chunk = self.sock.recv(4096)
            assert chunk, f"the cable line closed after {data!r}"
            data += chunk
        return data

    def setup(self, *commands: str) -> None:
        for command in commands:
            assert self.ask(command).endswith(b"OK\r\n"), command

    def close(self) -> None:
        self.sock.close()


def cable(world: World, *commands: str) -> None:
    """A whole cable session: ``commands``, ``write com close``, disconnect."""
    line = Cable(world.cable_port)
    try:
        line.setup(*commands, "write com close")
    finally:
        line.close()


def wait_for(what: Callable[[], Any], limit: float, step: float = 0.25) -> Any:
    """``what()`` until it is truthy or ``limit`` seconds passed; its last value."""
    deadline = time.monotonic() + limit
    while True:
        value = what()
        if value or time.monotonic() >= deadline:
            return value
        time.sleep(step)


def replies(world: World, number: str, text: str) -> list[str]:
    """The SMS delivered to ``number`` that contain ``text``."""
    return [m["text"] for m in world.phone.inbox(number) if text in m["text"]]


def registered(world: World, limit: float = 20.0) -> bool:
    """The logger set its modem up (``AT+CFUN=1``) and it is registered (the network says)."""
    if not in_trace(world, "AT+CFUN=1", limit):
        return False

    def check() -> bool:
        subs = world.phone.subscribers()
        return any(s["number"] == MODEM and s["registered"] for s in subs)

    return bool(wait_for(check, limit))


def stream(trace: str, direction: str = "logger>modem") -> str:
    """One direction of a trace joined (the trace cuts the bytes in chunks as they went)."""
    marker = f"  {direction}  "
    return "".join(x.split(marker, 1)[1] for x in trace.splitlines() if marker in x)


def in_trace(world: World, needle: str, limit: float, direction: str = "logger>modem") -> bool:
    """``needle`` (written as the trace writes it: ``\\r``) went that way within ``limit``."""
    return bool(wait_for(lambda: needle in stream(world.trace(), direction), limit, 0.05))


class DataCall:
    """A data call from ``caller`` to the logger's modem; the bridge is the caller's line."""

    def __init__(self, world: World, caller: str) -> None:
        self.world = world
        call = world.phone.call(caller, MODEM, "data")
        self.ident = int(call["call"])
        assert "bridge" in call, call
        self.sock = socket.create_connection(("127.0.0.1", call["bridge"]), timeout=10)
        self.received = b""
        self.reason: object = None

    def state(self) -> str:
        return str(self.world.phone.get_call(self.ident)["state"])

    def connected(self, limit: float = 30.0) -> bool:
        wait_for(lambda: self.state() != "ringing", limit)
        call = self.world.phone.get_call(self.ident)
        self.reason = call.get("reason")
        return bool(call["state"] == "connected")

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def expect(self, needle: bytes, limit: float = 10.0) -> bool:
        """Read until ``needle`` came (True) or ``limit`` passed or the call ended (False)."""
        deadline = time.monotonic() + limit
        while needle not in self.received:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self.sock.settimeout(left)
            try:
                data = self.sock.recv(4096)
            except (TimeoutError, OSError):
                continue
            if not data:
                return False
            self.received += data
        return True

    def listen(self, seconds: float) -> bytes:
        """Whatever else comes within ``seconds`` (also kept in :attr:`received`)."""
        before = len(self.received)
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            self.sock.settimeout(left)
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                continue
            except OSError:  # the bridge was cut: nothing more can come
                break
            if not data:
                break
            self.received += data
        return self.received[before:]

    def hang_up(self) -> None:
        if self.state() != "ended":
            self.world.phone.hang_up(self.ident)
        self.sock.close()
