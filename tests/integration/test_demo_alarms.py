"""``make demo`` shows its alarms end to end (issue 21): the river at ``CABLE-01`` floods a
module hour after the start, and the modem of ``GSM-03`` loses coverage half an hour later
(its e-mails stop: a ``no_contact`` alarm on its mailbox source). Each alarm is raised,
e-mailed through the demo's mail hub (read back over POP3) and texted through the demo's
GSM network (read back from the phone's inbox over the network's API), shown and
acknowledged on the dashboard, then cleared, which is e-mailed and texted too. Module time
runs at ``--speed`` 600 (a module hour in 6 s), so the whole path takes some 90 s after the
demo serves.
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
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from demo_process import DemoProcess

from sondalog.app.demo_alarms import MAILBOX_SOURCE, OPS_MAIL, RULE, SILENT_RULE, silent_after
from sondalog.app.demo_world import GSM_PHONE
from sondalog.client.phone import PhoneApi

SPEED = "600"
#: Real seconds from "Serving" to the cleared notifications (the flood takes ~25 s, the lost
#: coverage ~90 s: it starts 30 s after the network, lasts 8 module hours, then an e-mail).
WITHIN = 150.0
RULES = (RULE, SILENT_RULE)


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


@pytest.mark.timeout(360)
def test_demo_raises_notifies_acknowledges_and_clears_its_alarms(tmp_path: Path) -> None:
    with DemoProcess(tmp_path, "--speed", SPEED) as demo:
        demo.wait_for("Serving until Ctrl-C.", timeout=120)
        deadline = time.monotonic() + WITHIN
        web = demo.url("Dashboard:  ", r"http://127\.0\.0\.1:\d+/")
        pop3 = int(demo.url("POP3 127.0.0.1:", r"\d+"))
        api_given = re.search(r"sondalog phone --api (\S+) ", "".join(demo.lines))
        phone = PhoneApi(api_given.group(1) if api_given else "http://127.0.0.1:8025")
        assert "sondalog alarms list state/demo/collector.toml" in "".join(demo.lines)
        assert f"alarm {SILENT_RULE!r} is raised" in "".join(demo.lines)
        acked: dict[str, dict[str, Any]] = {}

        def raised_and_acknowledged() -> bool:
            """Each alarm acknowledged on the dashboard as soon as it is raised."""
            for alarm in get_json(web + "api/alarms")["active"]:
                rule = alarm["rule"]
                if rule in RULES and rule not in acked and alarm["state"] == "raised":
                    assert ack(web, alarm["id"]) == 202
                    acked[rule] = alarm
            return len(acked) == len(RULES)

        wait_until("both alarms raised", raised_and_acknowledged, deadline)
        flood, silent = acked[RULE], acked[SILENT_RULE]
        assert flood["subject"] == "CABLE-01/2" and flood["logger"] == "CABLE-01", flood
        assert flood["value"] > 1.6, flood
        # the mailbox answered all along: the alarm is the logger's silence, no failed poll
        assert silent["subject"] == MAILBOX_SOURCE, silent
        assert silent["value"] >= silent_after(float(SPEED)), silent

        def history(alarm: dict[str, Any], what: str) -> bool:
            past = get_json(web + "api/alarms")["history"]
            return any(h["id"] == alarm["id"] and h["what"] == what for h in past)

        for alarm in (flood, silent):
            for what in ("acknowledged", "cleared"):
                wait_until(what, partial(history, alarm, what), deadline)

        def mails() -> list[str] | None:
            got = subjects(pop3)
            done = all(
                any("RAISED" in s and rule in s for s in got)
                and any("CLEARED" in s and rule in s for s in got)
                for rule in RULES
            )
            return got if done else None

        got = wait_until("e-mails", mails, deadline)
        assert all(any(rule in s for rule in RULES) for s in got), got

        def texts() -> dict[str, list[str]] | None:
            inbox = [str(sms["text"]) for sms in phone.inbox(GSM_PHONE)]
            by_rule = {rule: [t for t in inbox if rule in t] for rule in RULES}
            done = all(
                any(t.startswith("ALARM:") for t in texts)
                and any(t.startswith("CLEARED:") for t in texts)
                for texts in by_rule.values()
            )
            return by_rule if done else None

        sms = wait_until("SMS", texts, deadline)
        for rule in RULES:  # one for the raise, one for the clear: no storm
            assert len(sms[rule]) == 2, sms
        active = get_json(web + "api/alarms")["active"]
        assert all(a["rule"] not in RULES for a in active), active
        demo.proc.send_signal(signal.SIGINT)
        assert demo.proc.wait(timeout=20) == 0
