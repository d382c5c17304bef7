"""The pure SMTP client core against scripted server lines (byte-exact)."""

from __future__ import annotations

import base64

import pytest

from sondalog.protocol.smtp_client import SmtpClient, SmtpReply, SmtpResult, dot_stuff

MSG = b"Subject: t\r\n\r\nline 1\r\n.dot\r\nOK\r\n"


def feed(client: SmtpClient, data: bytes, now: float = 1.0) -> bytes:
    client.receive_data(data, now)
    return client.data_to_send()


def events(client: SmtpClient) -> list[object]:
    out = []
    while (e := client.next_event()) is not None:
        out.append(e)
    return out


def test_plain_session_is_byte_exact() -> None:
    c = SmtpClient("logger@example.net", ["a@x.cz", "b@y.cz"], MSG, helo_name="ala1")
    c.start(0.0)
    assert c.data_to_send() == b""
    assert c.deadline == 60.0
    assert feed(c, b"220 mx ESMTP\r\n") == b"EHLO ala1\r\n"
    ehlo = b"250-mx\r\n250-8BITMIME\r\n250 HELP\r\n"
    assert feed(c, ehlo) == b"MAIL FROM:<logger@example.net>\r\n"
    assert feed(c, b"250 OK\r\n") == b"RCPT TO:<a@x.cz>\r\n"
    assert feed(c, b"250 OK\r\n") == b"RCPT TO:<b@y.cz>\r\n"
    assert feed(c, b"251 will forward\r\n") == b"DATA\r\n"
    assert feed(c, b"354 go ahead\r\n") == b"Subject: t\r\n\r\nline 1\r\n..dot\r\nOK\r\n.\r\n"
    assert c.result is None
    assert feed(c, b"250 queued as 1\r\n") == b"QUIT\r\n"
    assert c.result == SmtpResult("sent", "data", SmtpReply(250, ("queued as 1",)))
    assert not c.wants_close
    feed(c, b"221 bye\r\n")
    assert c.wants_close and c.deadline is None
    evs = events(c)
    assert evs[0] == SmtpReply(220, ("mx ESMTP",))
    assert SmtpReply(250, ("mx", "8BITMIME", "HELP")) in evs
    assert evs[-2] == c.result and evs[-1] == SmtpReply(221, ("bye",))


def test_auth_plain_when_offered() -> None:
    c = SmtpClient("l@x", ["u@x"], MSG, user="logger@example.net", password="s3 cret")
    c.start(0.0)
    feed(c, b"220 hi\r\n")
    token = base64.b64encode(b"\0logger@example.net\0s3 cret")
    assert feed(c, b"250-mx\r\n250 AUTH LOGIN PLAIN\r\n") == b"AUTH PLAIN " + token + b"\r\n"
    assert feed(c, b"235 2.7.0 Authentication successful\r\n") == b"MAIL FROM:<l@x>\r\n"


def test_auth_plain_answering_334_sends_the_token() -> None:
    c = SmtpClient("l@x", ["u@x"], MSG, user="u", password="p")
    c.start(0.0)
    feed(c, b"220 hi\r\n")
    token = base64.b64encode(b"\0u\0p")
    assert feed(c, b"250-mx\r\n250 AUTH PLAIN\r\n") == b"AUTH PLAIN " + token + b"\r\n"
    assert feed(c, b"334 \r\n") == token + b"\r\n"
    assert feed(c, b"235 ok\r\n") == b"MAIL FROM:<l@x>\r\n"


def test_auth_login_when_only_login_is_offered() -> None:
    c = SmtpClient("l@x", ["u@x"], MSG, user="jan@posta.cz", password="heslo")
    c.start(0.0)
    feed(c, b"220 hi\r\n")
    assert feed(c, b"250-mx\r\n250 AUTH=LOGIN\r\n") == b"AUTH LOGIN\r\n"
    assert feed(c, b"334 VXNlcm5hbWU6\r\n") == base64.b64encode(b"jan@posta.cz") + b"\r\n"
    assert feed(c, b"334 UGFzc3dvcmQ6\r\n") == base64.b64encode(b"heslo") + b"\r\n"
    assert feed(c, b"235 ok\r\n") == b"MAIL FROM:<l@x>\r\n"


def test_ehlo_refused_falls_back_to_helo() -> None:
    c = SmtpClient("", ["u@x"], MSG)
    c.start(0.0)
    feed(c, b"220 old server\r\n")
    assert feed(c, b"502 command not implemented\r\n") == b"HELO ala1\r\n"
    assert feed(c, b"250 hello\r\n") == b"MAIL FROM:<>\r\n"


def test_wrong_password_is_refused_with_the_reply_and_quits() -> None:
    c = SmtpClient("l@x", ["u@x"], MSG, user="u", password="bad")
    c.start(0.0)
    feed(c, b"220 hi\r\n")
    feed(c, b"250-mx\r\n250 AUTH PLAIN LOGIN\r\n")
    assert feed(c, b"535 5.7.8 Authentication credentials invalid\r\n") == b"QUIT\r\n"
    assert c.result is not None and c.result.outcome == "refused"
    assert c.result.stage == "auth plain"
    assert c.result.reply == SmtpReply(535, ("5.7.8 Authentication credentials invalid",))
    feed(c, b"221 bye\r\n")
    assert c.wants_close


def test_one_refused_recipient_refuses_the_message() -> None:
    c = SmtpClient("l@x", ["a@x", "nobody@x"], MSG)
    c.start(0.0)
    feed(c, b"220 hi\r\n")
    feed(c, b"250 mx\r\n")
    feed(c, b"250 ok\r\n")
    assert feed(c, b"250 ok\r\n") == b"RCPT TO:<nobody@x>\r\n"
    assert feed(c, b"550 5.1.1 no such mailbox\r\n") == b"QUIT\r\n"
    assert c.result is not None
    assert (c.result.outcome, c.result.stage) == ("refused", "rcpt")
    assert str(c.result) == "refused at rcpt: 550 5.1.1 no such mailbox"


def test_refused_greeting_and_refused_data() -> None:
    c = SmtpClient("l@x", ["a@x"], MSG)
    c.start(0.0)
    assert feed(c, b"554 go away\r\n") == b"QUIT\r\n"
    assert c.result is not None and c.result.outcome == "refused"
    c = SmtpClient("l@x", ["a@x"], MSG)
    c.start(0.0)
    for line in (b"220 hi\r\n", b"250 mx\r\n", b"250 ok\r\n", b"250 ok\r\n", b"354 go\r\n"):
        feed(c, line)
    assert feed(c, b"552 too big\r\n") == b"QUIT\r\n"
    assert c.result is not None and (c.result.outcome, c.result.stage) == ("refused", "body")


def test_byte_by_byte_input_gives_the_same_session() -> None:
    c = SmtpClient("l@x", ["a@x"], b"x")
    c.start(0.0)
    sent = b""
    script = (
        b"220 hi\r\n250-mx\r\n250 SIZE 1000\r\n250 ok\r\n250 ok\r\n354 go\r\n250 ok\r\n221 bye\r\n"
    )
    for i in range(len(script)):
        c.receive_data(script[i : i + 1], 1.0)
        sent += c.data_to_send()
    assert sent == (b"EHLO ala1\r\nMAIL FROM:<l@x>\r\nRCPT TO:<a@x>\r\nDATA\r\nx\r\n.\r\nQUIT\r\n")
    assert c.result is not None and c.result.sent and c.wants_close


def test_timeout_ends_without_quit() -> None:
    c = SmtpClient("l@x", ["a@x"], MSG, timeout=30.0)
    c.start(100.0)
    feed(c, b"220 hi\r\n", 110.0)
    assert c.deadline == 140.0
    c.handle_timeout(139.9)
    assert c.result is None
    c.handle_timeout(140.0)
    assert c.result is not None and (c.result.outcome, c.result.stage) == ("timeout", "ehlo")
    assert c.wants_close and c.data_to_send() == b""


def test_late_reply_counts_as_timeout() -> None:
    c = SmtpClient("l@x", ["a@x"], MSG, timeout=5.0)
    c.start(0.0)
    assert feed(c, b"220 hi\r\n", 6.0) == b""
    assert c.result is not None and c.result.outcome == "timeout"


@pytest.mark.parametrize(
    "data, detail",
    [(b"", "connection closed by server"), (b"hello there\r\n", "not an SMTP reply")],
)
def test_closed_or_garbage_is_broken(data: bytes, detail: str) -> None:
    c = SmtpClient("l@x", ["a@x"], MSG)
    c.start(0.0)
    c.receive_data(data, 1.0)
    assert c.result is not None and c.result.outcome == "broken"
    assert detail in c.result.detail and c.wants_close


def test_endless_line_is_broken() -> None:
    c = SmtpClient("l@x", ["a@x"], MSG)
    c.start(0.0)
    c.receive_data(b"2" * 5000, 1.0)
    assert c.result is not None and c.result.detail == "server line too long"


def test_dot_stuffing_and_line_ends() -> None:
    assert dot_stuff(b"a\n.b\r..c\rd") == b"a\r\n..b\r\n...c\r\nd\r\n.\r\n"
    assert dot_stuff(b"") == b".\r\n"
    assert dot_stuff(b".\r\n") == b"..\r\n.\r\n"


def test_bad_envelope_addresses_are_rejected() -> None:
    with pytest.raises(ValueError):
        SmtpClient("l@x", ["a@x\r\nRCPT TO:<b@x>"], MSG)
    with pytest.raises(ValueError):
        SmtpClient("l@x", [], MSG)
