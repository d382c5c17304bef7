"""The logger's pure SMTP and POP3 client cores over real TCP: against a plain aiosmtpd
server (recipes.md §4) and against our mail hub, with the faults of gsm.md §4."""

from __future__ import annotations

import asyncio
import mailbox
from email import policy
from email.parser import BytesParser
from pathlib import Path

from aiosmtpd.handlers import Mailbox
from aiosmtpd.smtp import SMTP, AuthResult, LoginPassword
from mail_servers import LOGGER, PASSWORD, USER, command_mail, free_port, hub, maildir_count, run

from sondalog.io.mail.client import check_mailbox, send_mail
from sondalog.protocol.mail_address import MailServer, parse_pop3_server, parse_smtp_server
from sondalog.protocol.mail_command import MailCommand, build_mail, parse_command_mail
from sondalog.protocol.pop3_client import Pop3Result

RESPONSE = "read channel 1 value\r\n.5 °C\r\nOK\r\n"


def reply_mail(to: str = USER) -> bytes:
    return build_mail(LOGGER, to, "ALA1 odpověď", RESPONSE)


def test_smtp_core_against_plain_aiosmtpd(tmp_path: Path) -> None:
    md_path = tmp_path / "md"

    def authenticator(
        server: SMTP, session: object, envelope: object, mech: str, data: object
    ) -> AuthResult:
        ok = isinstance(data, LoginPassword) and (data.login, data.password) == (b"u@x", b"p w")
        return AuthResult(success=ok, handled=False)

    async def main() -> None:
        loop = asyncio.get_running_loop()
        srv = await loop.create_server(
            lambda: SMTP(
                Mailbox(str(md_path)), authenticator=authenticator, auth_require_tls=False
            ),
            "127.0.0.1",
            0,
        )
        port = srv.sockets[0].getsockname()[1]
        try:
            good = parse_smtp_server(f"u@x:p w@127.0.0.1:{port}")
            sent = await send_mail(good, LOGGER, [USER], reply_mail(), timeout=5)
            assert sent.sent, str(sent)
            bad = MailServer("127.0.0.1", port, "u@x", "wrong")
            refused = await send_mail(bad, LOGGER, [USER], reply_mail(), timeout=5)
            assert refused.outcome == "refused" and refused.reply is not None
            assert refused.reply.code == 535
            anonymous = MailServer("127.0.0.1", port)  # aiosmtpd takes mail without AUTH
            assert (await send_mail(anonymous, LOGGER, [USER], b"x", timeout=5)).sent
        finally:
            srv.close()
            await srv.wait_closed()

    run(main())
    md = mailbox.Maildir(md_path, factory=None, create=False)
    got = sorted((md.get_bytes(k) for k in md.iterkeys()), key=len)
    assert len(got) == 2
    msg = BytesParser(policy=policy.default).parsebytes(got[1])
    assert str(msg["Subject"]) == "ALA1 odpověď"
    body = msg.get_body(("plain",))
    assert body is not None  # (the Maildir file has LF line ends, the wire had CRLF)
    assert body.get_payload(decode=True) == RESPONSE.replace("\r\n", "\n").encode()


def test_smtp_core_against_the_hub(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            server = parse_smtp_server(f"{LOGGER}:{PASSWORD}@127.0.0.1:{h.smtp_port}")
            sent = await send_mail(server, LOGGER, [USER], reply_mail(), timeout=5)
            assert sent.sent and sent.reply is not None and sent.reply.code == 250
            assert maildir_count(h.maildir(USER)) == 1
            unknown = await send_mail(server, LOGGER, ["x@example.net"], reply_mail(), timeout=5)
            assert (unknown.outcome, unknown.stage) == ("refused", "rcpt")
            assert unknown.reply is not None and unknown.reply.code == 550
            wrong = MailServer("127.0.0.1", h.smtp_port, LOGGER, "nope")
            refused = await send_mail(wrong, LOGGER, [USER], reply_mail(), timeout=5)
            assert refused.reply is not None and refused.reply.code == 535
            assert maildir_count(h.maildir(USER)) == 1
            # the message reads back through our POP3 server, byte for byte
            pop = MailServer("127.0.0.1", h.pop3_port, USER, PASSWORD)
            got = await check_mailbox(pop, max_size=10_000, time_limit=5)
            assert got.outcome == "mail" and got.message is not None
            assert got.message.endswith(reply_mail())

    run(main())


def test_no_server_listening_is_broken() -> None:
    async def main() -> None:
        port = free_port()
        result = await send_mail(MailServer("127.0.0.1", port), LOGGER, [USER], b"x", timeout=2)
        assert result.outcome == "broken" and "cannot connect" in result.detail
        check = await check_mailbox(
            MailServer("127.0.0.1", port, "u", "p"), max_size=1, time_limit=1, timeout=2
        )
        assert check.outcome == "broken"

    run(main())


def test_pop3_core_against_the_hub(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            box = parse_pop3_server(f"{LOGGER}:{PASSWORD}@127.0.0.1:{h.pop3_port}")
            assert (await check_mailbox(box, max_size=10_000, time_limit=5)).outcome == "none"
            h.accounts.deliver(LOGGER, command_mail().as_bytes())
            h.accounts.deliver(LOGGER, command_mail("##*#read time##*#").as_bytes())
            got = await check_mailbox(box, max_size=10_000, time_limit=5)
            assert got.outcome == "mail" and got.message is not None
            # the oldest message first; deleted once taken; the next waits for next time
            assert parse_command_mail(got.message) == MailCommand("read date", USER, "příkaz")
            assert maildir_count(h.maildir(LOGGER)) == 1
            again = await check_mailbox(box, max_size=10_000, time_limit=5)
            assert again.message is not None
            assert parse_command_mail(again.message) == MailCommand("read time", USER, "příkaz")
            wrong = MailServer("127.0.0.1", h.pop3_port, LOGGER, "wrong")
            bad = await check_mailbox(wrong, max_size=10_000, time_limit=5)
            assert bad.outcome == "auth_failed" and "[AUTH]" in bad.detail

    run(main())


def test_pop3_size_and_time_faults_against_the_hub(tmp_path: Path) -> None:
    async def main() -> None:
        async with hub(tmp_path) as h:
            box = MailServer("127.0.0.1", h.pop3_port, LOGGER, PASSWORD)
            big = command_mail("##*#read date##*#\n" + "x" * 2000).as_bytes()
            h.accounts.deliver(LOGGER, big)
            too_big = await check_mailbox(box, max_size=1000, time_limit=5)
            assert too_big.outcome == "too_big" and too_big.size is not None
            assert too_big.size > 1000
            assert maildir_count(h.maildir(LOGGER)) == 0  # deleted unread
            # a download longer than pop3 time: abandoned, still there next time
            huge = command_mail("##*#read date##*#\n" + "y" * 2_000_000).as_bytes()
            h.accounts.deliver(LOGGER, huge)
            slow = await check_mailbox(box, max_size=10_000_000, time_limit=0.001)
            assert (slow.outcome, slow.stage) == ("timeout", "retr"), str(slow)
            assert maildir_count(h.maildir(LOGGER)) == 1
            later = await _until_unlocked(box)
            assert later.outcome == "mail" and later.size == slow.size
            assert maildir_count(h.maildir(LOGGER)) == 0

    run(main())


async def _until_unlocked(box: MailServer) -> Pop3Result:
    """The hub notices the abandoned session a moment later; meanwhile it answers IN-USE."""
    for _ in range(100):
        result = await check_mailbox(box, max_size=10_000_000, time_limit=10)
        if not (result.outcome == "failed" and "IN-USE" in result.detail):
            return result
        await asyncio.sleep(0.02)
    raise AssertionError("the mailbox stayed in use")


def test_logger_reply_and_user_command_round_trip(tmp_path: Path) -> None:
    """The logger mails its response; the user's mail client answers with a command that the
    logger's next mailbox check finds, non-ASCII text intact."""

    async def main() -> None:
        async with hub(tmp_path) as h:
            smtp = MailServer("127.0.0.1", h.smtp_port)
            assert (await send_mail(smtp, LOGGER, [USER], reply_mail(), timeout=5)).sent
            user_box = MailServer("127.0.0.1", h.pop3_port, USER, PASSWORD)
            inbox = await check_mailbox(user_box, max_size=100_000, time_limit=5)
            assert inbox.message is not None
            answer = command_mail("Nastav prosím:\n##*#write channel 1 name/Čidlo °C/##*#")
            answer["Reply-To"] = "boss@example.net"
            user_smtp = MailServer("127.0.0.1", h.smtp_port, USER, PASSWORD)
            sent = await send_mail(user_smtp, USER, [LOGGER], answer.as_bytes(), timeout=5)
            assert sent.sent
            logger_box = MailServer("127.0.0.1", h.pop3_port, LOGGER, PASSWORD)
            got = await check_mailbox(logger_box, max_size=10_000, time_limit=5)
            assert got.message is not None
            assert parse_command_mail(got.message) == MailCommand(
                "write channel 1 name/Čidlo °C/", "boss@example.net", "příkaz"
            )

    run(main())
