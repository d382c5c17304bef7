"""The collector raises alarms and notifies (issue 21), for real: ``sondalog collect`` as a
subprocess against a served logger, e-mail to a real aiosmtpd, ``sondalog alarms list|ack``.

The logger's level channel follows a schedule (low, then high until the test switches the
channel to a low input) and its clock is set to now, so the readings' own times are the wall
clock's (repeats count from the raise's time)."""

from __future__ import annotations

import contextlib
import os
import signal
import sqlite3
import subprocess
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import pytest
from alarm_mail import MailSink, smtp_server
from served_logger import CLI, Served, serving

from sondalog.collect import config as collect_config
from sondalog.collect.alarms import alarm_id
from sondalog.collect.config import load_config
from sondalog.config import ConfigError

RULE = "level high"
SUBJECT = "000001/2"


def _site(tmp: Path, schedule: str) -> Path:
    """Analog input 16 follows ``schedule``; input 17 stays low (channel 2 is switched to it
    to clear the alarm when the test wants)."""
    site = tmp / "site.toml"
    site.write_text(
        "[logger]\n[[logger.analog]]\naddress = 16\n"
        f'signal = {{ model = "steps", schedule = {schedule} }}\n'
        '[[logger.analog]]\naddress = 17\nsignal = { model = "constant", value = 1.0 }\n'
    )
    return site


def _configure(served: Served) -> None:
    """Level on channel 2 (analog input 16), both channels sampled every second, the
    logger's clock at now (UTC)."""
    served.ask(
        "write date " + datetime.now(UTC).strftime("%Y%m%d%H%M%S"),
        "write channel max number 2",
        "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0",
        "write channel 2 name/Level[m]/ write channel 2 format 0.3",
        "write channel 1 record change 0 write channel 2 record change 0",
        "write channel sampling period 000001 000001",
    )


def _config(tmp: Path, url: str, port: int, rules: str) -> Path:
    path = tmp / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
        f'[[source]]\nurl = "{url}"\nname = "station"\ninterval = 0.5\ntimeout = 1\n'
        "retry = 0.3\nretry_max = 0.5\n\n"
        f'[[notify]]\nname = "mail"\nkind = "email"\nsmtp = "127.0.0.1:{port}"\n'
        'from = "collector@example.net"\nto = ["ops@example.net"]\nrepeat = "2s"\n'
        'backoff = "0.5s"\n\n'
        '[[notify]]\nname = "log"\nkind = "log"\n\n' + rules
    )
    return path


@contextlib.contextmanager
def _collecting(config: Path) -> Iterator[subprocess.Popen[bytes]]:
    proc = subprocess.Popen(
        [*CLI, "collect", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    try:
        yield proc
    finally:
        _stop(proc)


def _stop(proc: subprocess.Popen[bytes]) -> str:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err.decode(errors="replace") if err else ""


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=60)


def _outbox(store: Path) -> list[tuple[str, str]]:
    with contextlib.closing(sqlite3.connect(store)) as db:
        return db.execute("SELECT key, state FROM alarm_outbox ORDER BY created, key").fetchall()


def _state(store: Path, alarm: str) -> str | None:
    with contextlib.closing(sqlite3.connect(store)) as db:
        row = db.execute("SELECT state FROM alarm_states WHERE alarm = ?", (alarm,)).fetchone()
        return None if row is None else str(row[0])


def _what(mail: MailSink) -> list[str]:
    return [key.split("/")[1] for key in mail.sent_keys()]


THRESHOLD = f"""[[alarm]]
kind = "threshold"
name = "{RULE}"
channel = "Level"
above = 1.8
clear = 1.2
notify = ["mail", "log"]
"""


def test_threshold_raises_mails_is_listed_acknowledged_cleared_and_survives_restart(
    tmp_path: Path,
) -> None:
    site = _site(tmp_path, "[[0, 1.0], [3, 2.0]]")
    ident = alarm_id(RULE, SUBJECT)
    with (
        serving(tmp_path, "--site", str(site)) as served,
        smtp_server() as mail,
    ):
        config = _config(tmp_path, served.url, mail.port, THRESHOLD)
        assert _cli("collect", "--check", str(config)).returncode == 0
        store = tmp_path / "store.sqlite"
        with _collecting(config) as proc:
            _configure(served)
            mail.wait(lambda: "raised" in _what(mail))
            first = mail.mails[0]
            assert str(first["Subject"]).startswith("sondalog alarm RAISED: ")
            assert "above 1.8" in str(first["Subject"]) and "000001/2" in str(first["Subject"])
            assert first["To"] == "ops@example.net"
            listed = _cli("alarms", "list", str(config))
            assert listed.returncode == 0, listed.stderr
            line = next(x for x in listed.stdout.splitlines() if x.startswith(ident))
            assert " raised " in line and RULE in line and SUBJECT in line
            mail.wait(lambda: any(w.startswith("repeat") for w in _what(mail)), 6)
            acked = _cli("alarms", "ack", str(config), ident)
            assert acked.returncode == 0, acked.stderr
            mail.wait(lambda: _state(store, ident) == "acknowledged", 10)  # its next turn
            time.sleep(0.5)  # a repeat already being sent may still arrive
            count = len(mail.sent_keys())
            assert "acknowledged" in _cli("alarms", "list", str(config)).stdout
            again = _cli("alarms", "ack", str(config), ident)
            assert again.returncode == 2 and "acknowledged, not raised" in again.stderr
            time.sleep(3)  # two repeat periods: nothing more while acknowledged
            assert len(mail.sent_keys()) == count, mail.subjects()
            served.ask("write channel 2 address 17")  # the level falls
            mail.wait(lambda: "cleared" in _what(mail), 20)
            assert "CLEARED" in mail.subjects()[-1]
            time.sleep(1)
        err = _stop(proc)
        assert "alarm raised " + ident in err and "alarm cleared " + ident in err
        sent = mail.sent_keys()
        assert len(sent) == len(set(sent))  # nothing sent twice
        with _collecting(config):  # a restart neither forgets nor notifies again
            time.sleep(3)
        assert mail.sent_keys() == sent
        history = _cli("alarms", "list", "--all", str(config)).stdout
        assert "raised" in history and "cleared" in history and "acknowledged" in history
        assert {state for _, state in _outbox(store)} == {"sent"}


NO_CONTACT = """[[alarm]]
kind = "no_contact"
source = "station"
after = "2s"
notify = ["mail"]
"""


def test_no_contact_raised_when_the_logger_stops_and_a_kill_during_delivery_loses_nothing(
    tmp_path: Path,
) -> None:
    site = _site(tmp_path, "[[0, 1.0]]")
    with serving(tmp_path, "--site", str(site)) as served, smtp_server() as mail:
        _configure(served)
        config = _config(tmp_path, served.url, mail.port, NO_CONTACT)
        store = tmp_path / "store.sqlite"
        proc = subprocess.Popen(
            [*CLI, "collect", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        try:
            deadline = time.monotonic() + 20
            while not _query_ok(store):
                assert time.monotonic() < deadline, "the collector never contacted the logger"
                time.sleep(0.1)
            mail.hold = 3.0  # the server holds its answer: the collector is mid-delivery
            os.kill(served.proc.pid, signal.SIGSTOP)  # the logger stops answering
            assert mail.entered.wait(15), "no no-contact e-mail"
            proc.kill()  # kill -9 while the e-mail is being delivered
            proc.wait()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        mail.hold = 0.0
        assert _outbox(store)[0][1] == "pending"  # not marked sent: it must go again
        with _collecting(config) as again:
            mail.wait(lambda: _outbox(store)[0][1] == "sent", 15)
            os.kill(served.proc.pid, signal.SIGCONT)
            mail.wait(lambda: "cleared" in _what(mail), 15)
            # the server has the message before the collector has its answer and marks it
            # sent: a stop in between leaves it pending (sent again later, not lost)
            mail.wait(lambda: {state for _, state in _outbox(store)} == {"sent"}, 15)
        _stop(again)
    raised = [k for k in mail.sent_keys() if k.split("/")[1] == "raised"]
    assert 1 <= len(raised) <= 2 and len(set(raised)) == 1  # at least once, at most twice
    assert [w for w in _what(mail) if w == "cleared"] == ["cleared"]
    assert {state for _, state in _outbox(store)} == {"sent"}
    assert "NO_CONTACT" not in "".join(mail.subjects())  # the texts are the rule's words
    assert all("station" in s for s in mail.subjects())


def test_a_clean_stop_during_delivery_waits_for_the_answer_and_sends_nothing_twice(
    tmp_path: Path,
) -> None:
    """SIGTERM while the SMTP server holds its answer: the collector waits for it, marks
    the message sent, then stops; the restart does not send it again (a cancel would leave
    it pending, and the e-mail's thread would have delivered it all the same)."""
    site = _site(tmp_path, "[[0, 1.0]]")
    with serving(tmp_path, "--site", str(site)) as served, smtp_server() as mail:
        _configure(served)
        config = _config(tmp_path, served.url, mail.port, NO_CONTACT)
        store = tmp_path / "store.sqlite"
        with _collecting(config) as proc:
            mail.wait(lambda: _query_ok(store), 20)
            mail.hold = 2.0  # the server holds its answer: the collector is mid-delivery
            os.kill(served.proc.pid, signal.SIGSTOP)  # the logger stops answering
            assert mail.entered.wait(15), "no no-contact e-mail"
            err = _stop(proc)  # a clean stop while the e-mail is on its way
            assert proc.returncode == 0, err
        mail.hold = 0.0
        assert _outbox(store) and {state for _, state in _outbox(store)} == {"sent"}
        with _collecting(config):
            os.kill(served.proc.pid, signal.SIGCONT)
            mail.wait(lambda: "cleared" in _what(mail), 15)
            mail.wait(lambda: {state for _, state in _outbox(store)} == {"sent"}, 15)
    what = _what(mail)  # repeats (every 2 s while raised) may come in between
    assert what[0] == "raised" and what[-1] == "cleared"
    assert what.count("raised") == 1 and what.count("cleared") == 1


def _query_ok(store: Path) -> bool:
    with (
        contextlib.suppress(sqlite3.OperationalError),
        contextlib.closing(sqlite3.connect(store)) as db,
    ):
        row = db.execute("SELECT state FROM sources WHERE name = 'station'").fetchone()
        return row is not None and row[0] == "ok"
    return False


def test_ack_of_an_unknown_alarm_and_a_kind_without_a_sender_are_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = _config(tmp_path, "tcp://127.0.0.1:9", 25, THRESHOLD)
    refused = _cli("alarms", "ack", str(config), "0123456789")
    assert refused.returncode == 2 and "no alarm '0123456789'" in refused.stderr
    assert _cli("alarms", "list", str(config)).stdout.startswith("no alarms in ")
    assert load_config(config).alarms.rules[0].name == RULE
    monkeypatch.setattr(collect_config, "find_sender", lambda kind: None)
    with pytest.raises(ConfigError) as caught:
        load_config(config)
    text = str(caught.value)
    assert "collector.toml:" in text and "notify[0].kind" in text and "'email'" in text
    assert text.split(":")[1].strip().isdigit()  # FILE:LINE
