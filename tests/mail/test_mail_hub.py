"""The mail hub over real TCP: our POP3 server against stdlib ``poplib``, the aiosmtpd SMTP
server against stdlib ``smtplib``, delivery into Maildir read back through POP3."""

from __future__ import annotations

import asyncio
import errno
import poplib
import smtplib
import time
from email import policy
from email.parser import BytesParser
from pathlib import Path

import pytest
from mail_servers import (
    ACCOUNTS,
    LOGGER,
    PASSWORD,
    USER,
    command_mail,
    free_port,
    hub,
    maildir_count,
    run,
)

from sondalog.app.mailhub import MailHub, MailHubConfig, example_config, parse_mail
from sondalog.config import ConfigError, loads, of

RAW = [
    b"From: a@x.cz\nSubject: one\n\nfirst\n.leading dot\n",
    b"From: b@x.cz\nSubject: two\n\nsecond\n",
    b"From: c@x.cz\nSubject: three\n\n" + b"line\n" * 20,
]


def pop(port: int, user: str = LOGGER, password: str = PASSWORD) -> poplib.POP3:
    p = poplib.POP3("127.0.0.1", port, timeout=5)
    p.user(user)
    p.pass_(password)
    return p


def test_every_pop3_command_through_poplib(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            for raw in RAW:
                h.accounts.deliver(LOGGER, raw)
            await asyncio.to_thread(session, h.pop3_port, h.maildir(LOGGER))

    def session(port: int, maildir: Path) -> None:
        p = poplib.POP3("127.0.0.1", port, timeout=5)
        assert p.getwelcome().startswith(b"+OK")
        assert set(p.capa()) >= {"USER", "UIDL", "TOP", "RESP-CODES"}
        assert p.user(LOGGER).startswith(b"+OK")
        assert p.pass_(PASSWORD).startswith(b"+OK logged in, 3 messages")
        sizes = [len(r.replace(b"\n", b"\r\n")) for r in RAW]
        assert p.stat() == (3, sum(sizes))
        _, listing, _ = p.list()
        assert listing == [f"{i + 1} {s}".encode() for i, s in enumerate(sizes)]
        assert p.list(2) == f"+OK 2 {sizes[1]}".encode()
        _, uidls, _ = p.uidl()
        _, lines, octets = p.retr(1)  # poplib undoes the dot-stuffing
        assert lines == [b"From: a@x.cz", b"Subject: one", b"", b"first", b".leading dot"]
        assert octets > 0
        _, top, _ = p.top(3, 2)
        assert top == [b"From: c@x.cz", b"Subject: three", b"", b"line", b"line"]
        assert p.noop() == b"+OK"
        assert p.dele(1).startswith(b"+OK")
        with pytest.raises(poplib.error_proto, match="already deleted"):
            p.retr(1)
        assert p.stat()[0] == 2
        assert p.rset().startswith(b"+OK")
        assert p.stat()[0] == 3
        p.dele(2)
        # deletion happens only at QUIT: a session dropped now removes nothing
        p.sock.close()
        p.file.close()
        assert maildir_count(maildir) == 3
        p2 = _retry_login(port)
        assert p2.uidl()[1] == uidls  # UIDL stable across sessions
        p2.dele(2)
        assert maildir_count(maildir) == 3
        assert p2.quit().startswith(b"+OK bye, 1 messages deleted")
        assert maildir_count(maildir) == 2
        p3 = pop(port)
        assert p3.uidl()[1] == [b"1 " + uidls[0].split()[1], b"2 " + uidls[2].split()[1]]
        p3.quit()

    run(main())


def _retry_login(port: int) -> poplib.POP3:
    """The server may not have seen the dropped session end yet: [IN-USE] for a moment."""
    for _ in range(50):
        try:
            return pop(port)
        except poplib.error_proto as exc:
            if b"IN-USE" not in exc.args[0]:
                raise
            time.sleep(0.02)
    raise AssertionError("mailbox stayed in use")


def test_pop3_wrong_password_and_unknown_user(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            await asyncio.to_thread(check, h.pop3_port)

    def check(port: int) -> None:
        for user, password in ((LOGGER, "wrong"), ("nobody@example.net", PASSWORD)):
            p = poplib.POP3("127.0.0.1", port, timeout=5)
            p.user(user)
            with pytest.raises(poplib.error_proto, match=r"\[AUTH\]"):
                p.pass_(password)
            p.quit()

    run(main())


def test_smtp_delivery_into_maildir_then_pop3(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            await asyncio.to_thread(exchange, h)

    def exchange(h: MailHub) -> None:
        msg = command_mail("Příkaz:\n.##*#read date##*#\n")
        with smtplib.SMTP("127.0.0.1", h.smtp_port, timeout=5) as s:
            code, _ = s.ehlo("test")
            assert code == 250 and s.has_extn("auth")
            assert s.login(USER, PASSWORD)[0] == 235
            s.send_message(msg)
        assert maildir_count(h.maildir(LOGGER)) == 1
        assert maildir_count(h.maildir(USER)) == 0
        p = pop(h.pop3_port)
        _, lines, _ = p.retr(1)
        p.quit()
        got = BytesParser(policy=policy.default).parsebytes(b"\r\n".join(lines))
        assert got["Return-Path"] == f"<{USER}>" and got["Delivered-To"] == LOGGER
        assert got["Subject"] == msg["Subject"]
        body = got.get_body(("plain",))
        assert body is not None
        # (poplib returns lines without their ends, so the last line end is not seen)
        assert body.get_content().replace("\r\n", "\n") == "Příkaz:\n.##*#read date##*#"

    run(main())


def test_smtp_refusals(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            await asyncio.to_thread(refusals, h)

    def refusals(h: MailHub) -> None:
        with smtplib.SMTP("127.0.0.1", h.smtp_port, timeout=5) as s:
            with pytest.raises(smtplib.SMTPAuthenticationError) as auth:
                s.login(USER, "wrong")
            assert auth.value.smtp_code == 535
            with pytest.raises(smtplib.SMTPRecipientsRefused) as rcpt:
                s.sendmail(USER, ["nobody@example.net"], b"Subject: x\r\n\r\nx\r\n")
            code, text = rcpt.value.recipients["nobody@example.net"]
            assert code == 550 and b"no such mailbox" in text
            # one good recipient among bad ones: delivered to the good one only
            refused = s.sendmail(
                USER, ["nobody@example.net", LOGGER.upper()], b"Subject: y\r\n\r\ny"
            )
            assert list(refused) == ["nobody@example.net"]
        assert maildir_count(h.maildir(LOGGER)) == 1

    run(main())


def test_hub_binds_requested_ports_and_stops(tmp_path: Path) -> None:
    async def started() -> tuple[MailHub, int, int]:
        for _ in range(5):  # a free port can be taken by a parallel test before we bind it
            smtp_port, pop3_port = free_port(), free_port()
            cfg = MailHubConfig(tmp_path, ACCOUNTS, smtp_port=smtp_port, pop3_port=pop3_port)
            h = MailHub(cfg)
            try:
                await h.start()
            except OSError as exc:
                if exc.errno != errno.EADDRINUSE:
                    raise
                await h.stop()
                continue
            return h, smtp_port, pop3_port
        raise AssertionError("no free pair of ports in 5 tries")

    async def main() -> None:
        h, smtp_port, pop3_port = await started()
        assert (h.smtp_port, h.pop3_port) == (smtp_port, pop3_port)
        assert (tmp_path / LOGGER / "new").is_dir() and (tmp_path / USER / "cur").is_dir()
        # sessions still open when the hub stops are ended, not left behind
        pop_r, pop_w = await asyncio.open_connection("127.0.0.1", pop3_port)
        smtp_r, smtp_w = await asyncio.open_connection("127.0.0.1", smtp_port)
        assert (await pop_r.readline()).startswith(b"+OK")
        assert (await smtp_r.readline()).startswith(b"220")
        pop_w.write(f"USER {LOGGER}\r\nPASS {PASSWORD}\r\n".encode())
        assert (await pop_r.readline()).startswith(b"+OK")
        assert (await pop_r.readline()).startswith(b"+OK logged in")
        await asyncio.wait_for(h.stop(), 5)
        assert await asyncio.wait_for(pop_r.read(), 5) == b""
        assert await asyncio.wait_for(smtp_r.read(), 5) in (b"", b"421 closing\r\n")
        pop_w.close()
        smtp_w.close()
        with pytest.raises(RuntimeError):
            _ = h.smtp_port
        with pytest.raises(OSError):
            await asyncio.open_connection("127.0.0.1", pop3_port)

    run(main())


def test_site_file_mail_table(tmp_path: Path) -> None:
    site = loads(
        """
        [mail]
        smtp = "127.0.0.1:2526"
        pop3 = "127.0.0.1:1111"
        [mail.accounts]
        "logger@example.net" = "secret"
        """,
        tmp_path / "site.toml",
    )
    cfg = parse_mail(site.table("mail"), tmp_path)
    assert (cfg.smtp_port, cfg.pop3_port, dict(cfg.accounts)) == (
        2526,
        1111,
        {LOGGER: PASSWORD},
    )
    assert example_config(tmp_path).smtp_port == 2525
    assert example_config(tmp_path).pop3_port == 1110
    for bad, match in (
        ({"smtp": "2525"}, "mail.smtp: expected HOST:PORT"),
        ({"pop3": "h:99999"}, "mail.pop3: port must be a number"),
        ({"accounts": {"nobody": "x"}}, "mail.accounts.nobody: .*not an e-mail address"),
        ({"accounts": {LOGGER: 1}}, f'mail.accounts."{LOGGER}": must be a password'),
        ({"smpt": "h:1"}, "mail.smpt: unknown table or key 'smpt' .did you mean smtp"),
        ({"smtp_auth_required": "yes"}, "mail.smtp_auth_required: must be true or false"),
    ):
        with pytest.raises(ConfigError, match=match):
            parse_mail(of(bad, where="mail"), tmp_path)
