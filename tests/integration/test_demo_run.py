"""``python -m sondalog.demo`` (what ``make demo`` runs): the whole system, then Ctrl-C.

The demo is started as a subprocess in a temporary directory; the test reads the addresses
it prints, checks the dashboard shows both loggers with their history and the bus modules,
checks the rows every logger samples live carry values on every channel (issue 20), talks to
a logger and to the bus as the printed commands do, and stops it with SIGINT. Module time
runs at ``--speed`` :data:`SPEED` (a module hour in 6 s), so the hourly channels are sampled
live within seconds.
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from datetime import datetime
from pathlib import Path
from typing import Any

from demo_process import DemoProcess, assert_live_rows_carry_values

#: Module seconds per real second (the default, 60, takes a minute to sample hourly channels).
SPEED = "600"


def get_json(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return json.load(answer)


def wait_for_data(web: str, deadline: float) -> dict[str, Any]:
    """The overview once the loggers and both modules have readings."""
    while True:
        got = get_json(web + "api/loggers")
        by_name = {entry["logger"]: entry for entry in got["loggers"]}
        wanted = ("CABLE-01", "RAIN-02", "GSM-03", "bus:T1", "bus:H1")
        if all(by_name.get(k, {}).get("last_reading") for k in wanted):
            return by_name
        assert time.monotonic() < deadline, json.dumps(got, indent=1)
        time.sleep(0.5)


def _inbox(command: list[str]) -> str:
    run = subprocess.run(command, capture_output=True, text=True, timeout=30)
    return run.stdout + run.stderr


def closed(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=2).close()
    except OSError:
        return True
    return False


def test_demo_runs_the_whole_system_and_stops_on_ctrl_c(tmp_path: Path) -> None:
    with DemoProcess(tmp_path, "--speed", SPEED) as demo:
        text = demo.wait_for("Serving until Ctrl-C.")
        web = demo.url("Dashboard:  ", r"http://127\.0\.0\.1:\d+/")
        loggers = re.findall(r"sondalog term (tcp://127\.0\.0\.1:(\d+))", text)
        bus = demo.url("sondalog bus ask ", r"tcp://127\.0\.0\.1:\d+")
        assert len(loggers) == 3 and "sondalog bus scan tcp://" in text, text
        assert f"module time now runs {SPEED}x faster." in text  # what --speed asked for
        sms = re.search(r"sondalog phone ((?:--api \S+ )?)sms (\S+) (\S+) '([^']+)'", text)
        assert sms is not None, text

        # issue 20: the live loggers sample their simulated sensors (the site files), so
        # every channel has a value at each of its sampling instants
        for url, _ in loggers:
            assert assert_live_rows_carry_values(url) > 0

        entries = wait_for_data(web, time.monotonic() + 60)
        cable, rain = entries["CABLE-01"], entries["RAIN-02"]
        assert [c["name"] for c in cable["channels"]] == ["Supply", "Level", "Water"]
        assert [c["kind"] for c in rain["channels"]] == ["line", "line", "bars", "line", "line"]
        assert rain["signal"] is not None and rain["credit"] is not None
        assert cable["signal"] is None and cable["record_fill"].endswith("FILLING")
        assert not any(e["trouble"] for e in entries.values())
        # the GSM logger's rows came by e-mail through the mail hub, read from the mailbox
        gsm = entries["GSM-03"]
        assert [s["kind"] for s in gsm["sources"]] == ["mailbox"], gsm["sources"]
        assert gsm["signal"] is not None and gsm["credit"] == 250.0
        assert [c["channel"] for c in gsm["channels"]] == [1, 2, 3, 4]
        # the history was fast-forwarded: four weeks of 5-minute rows, plotted downsampled
        week = get_json(web + "api/loggers/CABLE-01/series")  # the default: the last 7 days
        assert all(len(s["t"]) > 1000 for s in week["series"]), week
        first, last = (datetime.fromisoformat(week[k]) for k in ("first", "last"))
        assert (last - first).days >= 27
        with urllib.request.urlopen(web, timeout=10) as page:
            assert "CABLE-01" in page.read().decode()

        # talk to a logger and to the bus as the printed commands do
        sondalog = [sys.executable, "-m", "sondalog"]
        term = subprocess.run(
            [*sondalog, "term", loggers[1][0]],
            input="read i snumber\n",
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert term.returncode == 0 and "RAIN-02" in term.stdout, term.stdout + term.stderr
        # text the GSM logger as the demo says: the reply comes by SMS
        phone = [*sondalog, "phone", *sms.group(1).split()]
        texted = subprocess.run(
            [*phone, "sms", sms.group(2), sms.group(3), sms.group(4)],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert texted.returncode == 0, texted.stdout + texted.stderr
        deadline = time.monotonic() + 60
        while "GSM-03" not in (inbox := _inbox([*phone, "inbox", sms.group(2)])):
            assert time.monotonic() < deadline, inbox
            time.sleep(1)
        ask = subprocess.run(
            # a reply's wait from the baud rate is a quarter second: too short for a loaded CI
            [*sondalog, "bus", "ask", bus, "T1", "PV", "--timeout", "2"],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert ask.returncode == 0 and re.search(r"\d", ask.stdout), ask.stdout + ask.stderr

        ports = [int(p) for _, p in loggers] + [int(web.rsplit(":", 1)[1].rstrip("/"))]
        demo.proc.send_signal(signal.SIGINT)
        assert demo.proc.wait(timeout=20) == 0
        assert "stopped." in demo.rest()
    assert all(closed(port) for port in ports)
    assert (tmp_path / "state" / "demo" / "cable" / "identity.json").exists()
    assert (tmp_path / "state" / "demo" / "collector.sqlite").exists()
