"""Soak the served example GSM world (issue 20; gsm.md §7 "Never miss, never stick").

Starts ``sondalog serve examples/gsm-site.toml`` (free loopback ports, a temp state dir), sets
the logger up over its cable line (``wavecom42``), then for ``--minutes`` drives it with
random timing (``--seed``): SMS commands from both phones, voice calls, data calls with
commands in them and the caller hanging up at random points, coverage cuts, cable sessions.
Then it lets the world go quiet (``--quiet`` seconds at most) and checks that every SMS
command got exactly one reply, that no SMS waits at the network and that the modem's SIM store
is empty (the API does not list it: ``AT+CPMS?`` on a second line into the modem, a Y-cable
the site gets for this). Prints a summary; exit 1 on any failure. Not a CI test.

    .venv/bin/python benchmarks/soak_served_gsm.py --minutes 1 --seed 7
"""

from __future__ import annotations

import argparse
import contextlib
import random
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from sondalog.client.phone import PhoneApi, PhoneApiError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "gsm"))

from gsm_served import example_text, free_port, serve

MODEM = "+420600000001"
PHONES = ("+420700000001", "+420700000002")
#: SMS commands and the text of their reply (replies are counted per phone and command).
COMMANDS = {"read i version": "2.10\r\n", "read com speed": "9600\r\n", "read i snumber": "000001"}


def start(state: Path, speed: float) -> tuple[subprocess.Popen[bytes], dict[str, int]]:
    text = example_text(free_port())
    # a second line into the modem (a Y-cable), only to ask AT+CPMS? at the end
    text = text.replace('# listen = "127.0.0.1:0"', 'listen = "127.0.0.1:0"')
    site = state.parent / "gsm-site.toml"
    site.write_text(text)
    extra = ("--speed", str(speed)) if speed != 1.0 else ()
    served = serve(site, state, *extra, until="logger com line joined", stderr=subprocess.DEVNULL)
    ports = {"cable": "logger ", "api": "gsm API", "modem": "gsm modem +"}
    return served.proc, {name: served.port(prefix) for name, prefix in ports.items()}


def ask(sock: socket.socket, command: str) -> bytes:
    sock.sendall(command.encode() + b"\r")
    data = b""
    while not data.endswith((b"OK\r\n", b"ERROR\r\n")):
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
    return data


def cable_session(port: int, commands: list[str]) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
            return all(ask(sock, c).endswith(b"OK\r\n") for c in [*commands, "write com close"])
    except OSError:
        return False


@dataclass
class Tally:
    sent: Counter[tuple[str, str]] = field(default_factory=Counter)
    counts: Counter[str] = field(default_factory=Counter)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, key: str, n: int = 1) -> None:
        with self.lock:
            self.counts[key] += n


class Soak:
    def __init__(self, api: PhoneApi, cable: int, seed: int) -> None:
        self.api, self.cable, self.rng = api, cable, random.Random(seed)
        self.tally = Tally()
        self.threads: list[threading.Thread] = []
        self.cuts = 0

    def spawn(self, target: object, *args: object) -> None:
        thread = threading.Thread(target=target, args=args, daemon=True)  # type: ignore[arg-type]
        thread.start()
        self.threads.append(thread)

    def sms(self) -> None:
        phone, command = self.rng.choice(PHONES), self.rng.choice(list(COMMANDS))
        try:
            self.api.sms(phone, MODEM, f"##*#{command}##*#")
            self.tally.sent[(phone, command)] += 1
        except PhoneApiError as exc:
            self.tally.add(f"sms refused: {exc.message}")

    def voice(self, phone: str, ring: float) -> None:
        try:
            call = self.api.call(phone, MODEM, "voice")
            self.tally.add("voice calls")
            time.sleep(ring)
            if self.api.get_call(call["call"])["state"] != "ended":
                self.api.hang_up(call["call"])
        except PhoneApiError:
            self.tally.add("voice refused")

    def data(self, phone: str, commands: int, hang_after: float | None) -> None:
        """A data call: ``commands`` command lines, or hang up after ``hang_after`` s."""
        try:
            call = self.api.call(phone, MODEM, "data")
        except PhoneApiError:
            self.tally.add("data refused")
            return
        self.tally.add("data calls")
        if "bridge" not in call:
            self.tally.add("data calls not connected")
            return
        start = time.monotonic()
        with socket.create_connection(("127.0.0.1", call["bridge"]), timeout=5) as sock:
            while self.api.get_call(call["call"])["state"] == "ringing":
                if hang_after is not None and time.monotonic() - start > hang_after:
                    break
                time.sleep(0.3)
            state = self.api.get_call(call["call"])["state"]
            if state == "connected":
                self.tally.add("data calls connected")
                for _ in range(commands):
                    if hang_after is not None and time.monotonic() - start > hang_after:
                        break
                    try:
                        sock.sendall(b"read i version\r")
                    except OSError:  # the call ended under the caller (a coverage cut)
                        self.tally.add("data calls cut")
                        break
                    got, deadline = b"", time.monotonic() + 15
                    while b"OK\r\n" not in got and time.monotonic() < deadline:
                        with contextlib.suppress(OSError):  # a timeout; the call gone
                            got += sock.recv(4096) or b"\0"
                    key = "2.10\r\nOK" in got.decode("latin-1")
                    self.tally.add("data commands answered" if key else "data commands unanswered")
                    time.sleep(self.rng.uniform(0, 3))
        if self.api.get_call(call["call"])["state"] != "ended":
            self.api.hang_up(call["call"])

    def cut(self, seconds: float) -> None:
        self.api.coverage(MODEM, False)
        time.sleep(seconds)
        self.api.coverage(MODEM, True)

    def cable_session(self) -> None:
        ok = cable_session(self.cable, ["read i version", "read com speed"])
        self.tally.add("cable sessions" if ok else "cable sessions failed")

    def step(self) -> None:
        rng = self.rng
        action = rng.choices(["sms", "voice", "data", "cut", "cable"], [8, 1, 2, 1, 1])[0]
        if action == "sms":
            self.sms()
        elif action == "voice":
            self.spawn(self.voice, rng.choice(PHONES), rng.uniform(0, 8))
        elif action == "data":
            hang = rng.choice([None, rng.uniform(0, 20)])
            self.spawn(self.data, rng.choice(PHONES), rng.randint(0, 4), hang)
        elif action == "cut":
            self.cuts += 1
            self.spawn(self.cut, rng.uniform(1, 20))
        else:
            self.spawn(self.cable_session)

    def replies(self) -> Counter[tuple[str, str]]:
        got: Counter[tuple[str, str]] = Counter()
        for phone in PHONES:
            for sms in self.api.inbox(phone):
                for command, text in COMMANDS.items():
                    if sms["text"].startswith(text):
                        got[(phone, command)] += 1
        return got


def store_used(port: int) -> int:
    """The modem's SIM store: ``AT+CPMS?`` (read-only) on the modem's second line."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
        sock.sendall(b"AT+CPMS?\r")
        data, deadline = b"", time.monotonic() + 10
        while b"OK\r\n" not in data and time.monotonic() < deadline:
            data += sock.recv(4096)
    found = re.search(rb'\+CPMS: "SM",(\d+),', data)
    if found is None:
        raise SystemExit(f"AT+CPMS? answered {data!r}")
    return int(found.group(1))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--speed", type=float, default=1.0, help="passed to sondalog serve")
    parser.add_argument("--mean-gap", type=float, default=3.0, help="mean seconds between actions")
    parser.add_argument("--quiet", type=float, default=200.0, help="most seconds to go quiet")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="soak-gsm-") as tmp:
        state = Path(tmp) / "state"
        proc, ports = start(state, args.speed)
        api = PhoneApi(f"http://127.0.0.1:{ports['api']}")
        try:
            if not cable_session(ports["cable"], ["write com device wavecom42",
                                                  "write com network delay 2"]):  # fmt: skip
                raise SystemExit("the logger refused its setup")
            soak = Soak(api, ports["cable"], args.seed)
            end = time.monotonic() + args.minutes * 60
            while time.monotonic() < end:
                soak.step()
                time.sleep(soak.rng.expovariate(1 / args.mean_gap))
            for thread in soak.threads:
                thread.join(60)
            api.coverage(MODEM, True)
            quiet_end, stable_since = time.monotonic() + args.quiet, None
            while time.monotonic() < quiet_end:  # go quiet: until all is answered, 20 s stable
                if soak.replies() == soak.tally.sent:
                    stable_since = stable_since or time.monotonic()
                    if time.monotonic() - stable_since > 20:
                        break
                else:
                    stable_since = None
                time.sleep(2)
            got = soak.replies()
            left = store_used(ports["modem"])
            queued = next(s["queued"] for s in api.subscribers() if s["number"] == MODEM)
        finally:
            proc.terminate()
            proc.wait(15)
    sent = soak.tally.sent
    keys = set(sent) | set(got)
    once = sum(min(sent[k], got[k]) for k in keys)
    missing = sum(max(0, sent[k] - got[k]) for k in keys)
    twice = sum(max(0, got[k] - sent[k]) for k in keys)
    print(f"seed {args.seed}, {args.minutes} min, speed {args.speed}")
    print(f"SMS commands sent         {sum(sent.values())}")
    print(f"  answered once           {once}")
    print(f"  unanswered              {missing}")
    print(f"  answered twice+         {twice}")
    for key, value in sorted(soak.tally.counts.items()):
        print(f"{key:<26}{value}")
    print(f"coverage cuts             {soak.cuts}")
    print(f"SMS left at network       {queued}")
    print(f"SIM store left (CPMS)     {left}")
    failed = missing or twice or queued or left
    print("FAIL" if failed else "OK")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
