"""The logger's POP3 mailbox check against Debian's dovecot-pop3d (a real peer)."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from mail_servers import LOGGER, PASSWORD, USER, Dovecot, command_mail, dovecot, maildir_count, run

from sondalog.io.mail.client import check_mailbox
from sondalog.protocol.mail_address import parse_pop3_server
from sondalog.protocol.mail_command import MailCommand, NoCommand, parse_command_mail
from sondalog.protocol.pop3_client import Pop3Result


@pytest.fixture(scope="module")
def server() -> Iterator[Dovecot]:
    with dovecot() as d:
        yield d


@pytest.fixture()
def box(server: Dovecot) -> Iterator[Dovecot]:
    server.clear()
    server.chown()
    yield server


def check(d: Dovecot, password: str = PASSWORD, **kw: float) -> Pop3Result:
    spec = parse_pop3_server(f"{LOGGER}:{password}@127.0.0.1:{d.port}")
    limits = {"max_size": 10_000, "time_limit": 10.0} | kw
    return run(
        check_mailbox(spec, max_size=int(limits["max_size"]), time_limit=limits["time_limit"]),
    )


def test_command_mail_taken_and_deleted(box: Dovecot) -> None:
    box.put(command_mail().as_bytes())
    box.put(command_mail("##*#read time##*#").as_bytes())
    got = check(box)
    assert got.outcome == "mail" and got.message is not None, f"{got}\n{box.log()}"
    assert parse_command_mail(got.message) == MailCommand("read date", USER, "příkaz")
    assert maildir_count(box.maildir) == 1
    nxt = check(box)
    assert nxt.message is not None
    assert parse_command_mail(nxt.message) == MailCommand("read time", USER, "příkaz")
    assert check(box).outcome == "none"
    assert maildir_count(box.maildir) == 0


def test_too_big_deleted_unread_and_malformed_mail(box: Dovecot) -> None:
    box.put(command_mail("##*#read date##*#\n" + "x" * 3000).as_bytes())
    broken = (
        b"From: user@example.net\nSubject: b\nContent-Transfer-Encoding: base64\n\n"
        b"##*#global reset##*#\n"
    )
    box.put(broken)
    got = check(box, max_size=1000)
    assert got.outcome == "too_big" and got.message is None and (got.size or 0) > 3000
    assert maildir_count(box.maildir) == 1
    bad = check(box)
    assert bad.outcome == "mail" and bad.message is not None  # taken and deleted ...
    assert parse_command_mail(bad.message) == NoCommand("broken base64 body")  # ... not run
    assert maildir_count(box.maildir) == 0


def test_download_over_pop3_time_is_left_for_next_time(box: Dovecot) -> None:
    box.put(command_mail("##*#read date##*#\n" + "y" * 2_000_000).as_bytes())
    slow = check(box, max_size=10_000_000, time_limit=0.001)
    assert (slow.outcome, slow.stage) == ("timeout", "retr"), str(slow)
    assert maildir_count(box.maildir) == 1
    for _ in range(50):  # dovecot may still be finishing the dropped session
        later = check(box, max_size=10_000_000)
        if later.outcome == "mail":
            break
        time.sleep(0.05)
    assert later.outcome == "mail" and later.size == slow.size, str(later)
    assert maildir_count(box.maildir) == 0


# Last and only one: after a failed login dovecot delays the next logins from the same
# address by seconds (its auth penalty).
def test_wrong_password(box: Dovecot) -> None:
    box.put(command_mail().as_bytes())
    got = check(box, password="wrong")
    assert got.outcome == "auth_failed", str(got)
    assert maildir_count(box.maildir) == 1
