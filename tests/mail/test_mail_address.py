"""Server specs and e-mail address values (§6.10.3, §6.11.6.3, §6.11.6.4.1)."""

from __future__ import annotations

import pytest

from sondalog.protocol.mail_address import (
    MailAddressError,
    MailServer,
    parse_email_value,
    parse_pop3_server,
    parse_smtp_server,
)


def test_manual_pop3_example() -> None:
    # §6.11.6.4.1: jan.novak@posta.cz:heslo@pop3.posta.cz
    s = parse_pop3_server("jan.novak@posta.cz:heslo@pop3.posta.cz")
    assert s == MailServer("pop3.posta.cz", 110, "jan.novak@posta.cz", "heslo")
    assert str(s) == "jan.novak@posta.cz:***@pop3.posta.cz:110"


@pytest.mark.parametrize(
    "text, server",
    [
        ("smtp.example.net", MailServer("smtp.example.net", 25)),
        ("smtp.example.net:2525", MailServer("smtp.example.net", 2525)),
        ("u:p@127.0.0.1:2525", MailServer("127.0.0.1", 2525, "u", "p")),
        ("logger@example.net:se:cret@smtp.example.net", None),
        ("a@b.cz:@h", MailServer("h", 25, "a@b.cz", "")),
    ],
)
def test_smtp_specs(text: str, server: MailServer | None) -> None:
    parsed = parse_smtp_server(text)
    if server is None:  # the password holds ':' after the first one
        assert (parsed.user, parsed.password, parsed.host) == (
            "logger@example.net",
            "se:cret",
            "smtp.example.net",
        )
    else:
        assert parsed == server


@pytest.mark.parametrize(
    "text",
    ["", "   ", "host:0", "host:70000", "host:x", "user@host", ":p@host", "u:p@", "a b:25"],
)
def test_bad_smtp_specs(text: str) -> None:
    with pytest.raises(MailAddressError):
        parse_smtp_server(text)


def test_pop3_needs_credentials() -> None:
    with pytest.raises(MailAddressError, match="user:password"):
        parse_pop3_server("pop3.example.net")
    assert parse_pop3_server("u:p@pop3.example.net:1110").port == 1110


def test_email_values() -> None:
    # §6.10.3: an address, optionally followed by @ and an SMTP server spec
    assert parse_email_value("MyALA@ala1.com") == ("MyALA@ala1.com", None)
    assert parse_email_value("user@example.net@smtp.example.net:2525") == (
        "user@example.net",
        MailServer("smtp.example.net", 2525),
    )
    assert parse_email_value("user@example.net@jan@posta.cz:heslo@smtp.posta.cz") == (
        "user@example.net",
        MailServer("smtp.posta.cz", 25, "jan@posta.cz", "heslo"),
    )
    for bad in ("no-at-sign", "@example.net", "user@", "a b@c.cz", "user@example.net@"):
        with pytest.raises(MailAddressError):
            parse_email_value(bad)
