"""``make demo`` shows an alarm end to end (issue 21): the river at ``CABLE-01`` floods a
module hour after the start; the alarm is raised, e-mailed through the demo's mail hub
(read back over POP3) and texted through the demo's GSM network (read back from the
phone's inbox over the network's API), shown and acknowledged on the dashboard, then
cleared, which is e-mailed and texted too. Module time runs at ``--speed`` 600 (a module
hour in 6 s), so the whole path takes well under a minute after the demo serves.
"""

from __future__ import annotations

import json
import poplib
import re
import signal
import time
import urllib.request
from email import message_from_bytes
from email.header import decode_header, make_header
from pathlib import Path
from typing import Any

from demo_process import DemoProcess

from sondalog.app.demo_alarms import OPS_MAIL, RULE
from sondalog.app.demo_world import GSM_PHONE
from sondalog.client.phone import PhoneApi

SPEED = "600"
#: Real seconds from "Serving" to the cleared notifications (the flood takes ~25 s).
WITHIN = 60.0


def get_json(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return json.load(answer)


def ack(web: str, alarm: str) -> int:
    """The dashboard's Acknowledge button: a POST from its own page (``Origin``)."""
    request = urllib.request.Request(
        f"{web}api/alarms/{alarm}/ack",
        data=b"{}",
        method="POST",
        headers={"Origin": web.rstrip("/"), "Content-Type": "application/json"},
    )
    with urllib.request.urlopen(request, timeout=10) as answer:
        return int(answer.status)


def subjects(port: int) -> list[str]:
    """The subjects of the mails in the ops account (POP3, the messages left there)."""
    pop = poplib.POP3("127.0.0.1", port, timeout=10)
    try:
        pop.user(OPS_MAIL)
        pop.pass_("secret")
        out = []
        for number in range(1, len(pop.list()[1]) + 1):
            mail = message_from_bytes(b"\n".join(pop.retr(number)[1]))
            out.append(str(make_header(decode_header(mail["Subject"] or ""))))
        return out
    finally:
        pop.quit()


def wait_until(what: str, check: Any, deadline: float) -> Any:
    while not (got := check()):
        assert time.monotonic() < deadline, f"no {what} in time"
        time.sleep(0.3)
    return got


def test_demo_raises_notifies_acknowledges_and_clears_the_flood_alarm(tmp_path: Path) -> None:
    with DemoProcess(tmp_path, "--speed", SPEED) as demo:
        demo.wait_for("Serving until Ctrl-C.", timeout=120)
        deadline = time.monotonic() + WITHIN
        web = demo.url("Dashboard:  ", r"http://127\.0\.0\.1:\d+/")
        pop3 = int(demo.url("POP3 127.0.0.1:", r"\d+"))
        api_given = re.search(r"sondalog phone --api (\S+) ", "".join(demo.lines))
        phone = PhoneApi(api_given.group(1) if api_given else "http://127.0.0.1:8025")
        assert "sondalog alarms list state/demo/collector.toml" in "".join(demo.lines)

        def raised() -> dict[str, Any] | None:
            on = get_json(web + "api/alarms")["active"]
            return next((a for a in on if a["rule"] == RULE), None)

        alarm = wait_until("raised alarm on the dashboard", raised, deadline)
        assert alarm["subject"] == "CABLE-01/2" and alarm["logger"] == "CABLE-01", alarm
        assert alarm["state"] == "raised" and alarm["value"] > 1.6, alarm
        assert ack(web, alarm["id"]) == 202

        def history(what: str) -> bool:
            past = get_json(web + "api/alarms")["history"]
            return any(h["id"] == alarm["id"] and h["what"] == what for h in past)

        wait_until("acknowledgement", lambda: history("acknowledged"), deadline)
        wait_until("clear", lambda: history("cleared"), deadline)

        def mails() -> list[str] | None:
            got = subjects(pop3)
            done = any("RAISED" in s for s in got) and any("CLEARED" in s for s in got)
            return got if done else None

        got = wait_until("e-mails", mails, deadline)
        assert all(RULE in s for s in got), got

        def texts() -> list[str] | None:
            inbox = [str(sms["text"]) for sms in phone.inbox(GSM_PHONE)]
            alarm_sms = [t for t in inbox if RULE in t]
            done = any(t.startswith("ALARM:") for t in alarm_sms) and any(
                t.startswith("CLEARED:") for t in alarm_sms
            )
            return alarm_sms if done else None

        sms = wait_until("SMS", texts, deadline)
        assert len(sms) == 2, sms  # one for the raise, one for the clear: no storm
        assert get_json(web + "api/alarms")["active"] == [] or all(
            a["rule"] != RULE for a in get_json(web + "api/alarms")["active"]
        )
        demo.proc.send_signal(signal.SIGINT)
        assert demo.proc.wait(timeout=20) == 0
