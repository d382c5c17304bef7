"""Commands in SMS and e-mail texts, and the logger's outgoing e-mail (§3.4.6, §6.12, §6.13)."""

from __future__ import annotations

import base64
from datetime import UTC, datetime
from email import policy
from email.message import EmailMessage
from email.parser import BytesParser

import pytest

from sondalog.protocol.mail_command import (
    BoundedCommand,
    MailCommand,
    NoCommand,
    build_mail,
    extract_command,
    parse_command_mail,
)


def test_sms_command_and_return_address() -> None:
    assert extract_command("##*#read date##*#") == BoundedCommand("read date")
    text = "hi startemail me@example.net endemail ##*# read channel 1 value ##*# bye ##*#"
    assert extract_command(text) == BoundedCommand("read channel 1 value", "me@example.net")
    assert extract_command("[read date]", boundary="[") == NoCommand(
        "the command boundary '[' occurs only once"
    )
    assert extract_command("%%read date%%", boundary="%%") == BoundedCommand("read date")


@pytest.mark.parametrize(
    "text, reason",
    [
        ("read date", "no command boundary '##*#'"),
        ("##*#read date", "the command boundary '##*#' occurs only once"),
        ("##*#  \r\n##*#", "nothing between the command boundaries"),
    ],
)
def test_sms_without_command(text: str, reason: str) -> None:
    assert extract_command(text) == NoCommand(reason)


def test_bad_return_address_replies_by_sms() -> None:
    got = extract_command("startemail not an address endemail ##*#read date##*#")
    assert isinstance(got, BoundedCommand) and got.return_address is None
    assert "no e-mail address" in got.note
    got = extract_command("startemail me@example.net ##*#read date##*#")
    assert isinstance(got, BoundedCommand) and got.return_address is None
    assert "without 'endemail'" in got.note
    # markers inside the command are part of the command, not an address
    got = extract_command("##*#write x startemail a@b.cz endemail##*#")
    assert got == BoundedCommand("write x startemail a@b.cz endemail")


def mail(body: bytes, headers: bytes = b"From: Jan <jan@example.net>\r\n") -> bytes:
    return headers + b"Subject: cmd\r\n" + body


def test_plain_mail_replies_to_reply_to_else_from() -> None:
    raw = mail(b"\r\n##*#read date##*#\r\n")
    assert parse_command_mail(raw) == MailCommand("read date", "jan@example.net", "cmd")
    raw = mail(b"\r\n##*#read date##*#\r\n", b"From: jan@example.net\r\nReply-To: <r@x.cz>\r\n")
    assert parse_command_mail(raw) == MailCommand("read date", "r@x.cz", "cmd")


def test_quoted_printable_and_base64_non_ascii() -> None:
    qp = mail(
        b"Content-Type: text/plain; charset=iso-8859-2\r\n"
        b"Content-Transfer-Encoding: quoted-printable\r\n\r\n"
        b"P=F8=EDkaz: ##*#write channel 1 name/Teplota =E8idla/##*#=\r\n konec\r\n"
    )
    got = parse_command_mail(qp)
    assert isinstance(got, MailCommand) and got.command == "write channel 1 name/Teplota čidla/"
    b64 = base64.encodebytes("Příkaz ##*#read date##*# díky".encode()).replace(b"\n", b"\r\n")
    raw = mail(
        b"Content-Type: text/plain; charset=utf-8\r\nContent-Transfer-Encoding: base64\r\n\r\n"
        + b64
    )
    assert parse_command_mail(raw) == MailCommand("read date", "jan@example.net", "cmd")


def test_first_plain_part_of_a_multipart_mail() -> None:
    msg = EmailMessage()
    msg["From"] = "jan@example.net"
    msg["Subject"] = "Příkaz"
    msg.set_content("##*#read date##*#")
    msg.add_alternative("<p>##*#global reset##*#</p>", subtype="html")
    msg.add_attachment(b"##*#global reset##*#", maintype="text", subtype="plain")
    got = parse_command_mail(msg.as_bytes())
    assert got == MailCommand("read date", "jan@example.net", "Příkaz")
    html = EmailMessage()
    html["From"] = "jan@example.net"
    html.set_content("<p>##*#read date##*#</p>", subtype="html")
    assert parse_command_mail(html.as_bytes()) == NoCommand("no text/plain part")


@pytest.mark.parametrize(
    "raw, reason",
    [
        (mail(b"\r\nno command here\r\n"), "no command boundary '##*#'"),
        (
            mail(b"Content-Transfer-Encoding: base64\r\n\r\n##*#read date##*#\r\n"),
            "broken base64 body",
        ),
        (
            mail(b"Content-Transfer-Encoding: base64\r\n\r\nIyMqI3JlYWQgZGF0ZSMjKi\r\n"),
            "broken base64 body",
        ),
        (
            mail(b"Content-Type: text/plain; charset=utf-8\r\n\r\n##*#\xff\xfe##*#\r\n"),
            "body is not valid utf-8",
        ),
        (mail(b"Content-Type: text/plain; charset=klingon\r\n\r\n##*#x##*#"), "unknown charset"),
        (b"Subject: x\r\n\r\n##*#read date##*#\r\n", "no Reply-To or From address to answer"),
        (b"\x00\xff garbage without headers", "no Reply-To or From address to answer"),
    ],
)
def test_malformed_mails_hold_no_command(raw: bytes, reason: str) -> None:
    got = parse_command_mail(raw)
    assert isinstance(got, NoCommand) and got.reason.startswith(reason)


def test_utf8_without_charset_is_still_read() -> None:
    raw = mail("\r\n##*#write channel 1 name/Čidlo/##*#\r\n".encode())
    got = parse_command_mail(raw)
    assert isinstance(got, MailCommand) and got.command == "write channel 1 name/Čidlo/"


def test_outgoing_mail_is_byte_exact() -> None:
    when = datetime(2026, 11, 30, 1, 0, 0, tzinfo=UTC)
    raw = build_mail(
        "logger@example.net",
        "user@example.net",
        "ALA1 data",
        "read date\r\n2026-11-30 01:00:00\r\n.\r\nOK\r\n",
        date=when,
        message_id="<1@ala1>",
    )
    assert raw == (
        b"From: logger@example.net\r\nTo: user@example.net\r\nSubject: ALA1 data\r\n"
        b"Date: Mon, 30 Nov 2026 01:00:00 +0000\r\nMessage-ID: <1@ala1>\r\n"
        b'Content-Type: text/plain; charset="us-ascii"\r\nContent-Transfer-Encoding: 7bit\r\n'
        b"MIME-Version: 1.0\r\n\r\nread date\r\n2026-11-30 01:00:00\r\n.\r\nOK\r\n"
    )


def test_outgoing_non_ascii_mail_round_trips() -> None:
    body = "channel 1 name/Teplota °C/\r\nOK\r\n"
    raw = build_mail("logger@example.net", "user@example.net", "Měření", body)
    assert raw.isascii()
    msg = BytesParser(policy=policy.default).parsebytes(raw)
    assert str(msg["Subject"]) == "Měření"
    assert msg["Content-Transfer-Encoding"] == "quoted-printable"
    part = msg.get_body(("plain",))
    assert part is not None
    assert part.get_payload(decode=True) == body.encode()
