"""The pure POP3 command-mailbox check against scripted server lines (byte-exact)."""

from __future__ import annotations

from sondalog.protocol.pop3_client import Pop3Check, Pop3Response, Pop3Result


def feed(c: Pop3Check, data: bytes, now: float = 1.0) -> bytes:
    c.receive_data(data, now)
    return c.data_to_send()


def login(c: Pop3Check, now: float = 1.0) -> None:
    c.start(0.0)
    assert feed(c, b"+OK POP3 ready\r\n", now) == b"USER logger@example.net\r\n"
    assert feed(c, b"+OK\r\n", now) == b"PASS secret\r\n"
    assert feed(c, b"+OK Logged in.\r\n", now) == b"STAT\r\n"


def check(**kw: float) -> Pop3Check:
    args: dict[str, float] = {"max_size": 1000, "time_limit": 20.0, "timeout": 60.0} | kw
    return Pop3Check(
        "logger@example.net",
        "secret",
        max_size=int(args["max_size"]),
        time_limit=args["time_limit"],
        timeout=args["timeout"],
    )


def test_command_mail_is_taken_byte_exact() -> None:
    c = check()
    login(c)
    assert feed(c, b"+OK 2 320\r\n") == b"LIST 1\r\n"
    assert feed(c, b"+OK 1 120\r\n") == b"RETR 1\r\n"
    assert feed(c, b"+OK 120 octets\r\nSubject: x\r\n\r\n..dot\r\n") == b""
    assert feed(c, b"##*#read date##*#\r\n.\r\n") == b"DELE 1\r\n"
    assert c.result is None
    assert feed(c, b"+OK Marked to be deleted.\r\n") == b"QUIT\r\n"
    assert c.result is None  # taken only once the server confirms the deletion
    feed(c, b"+OK Logging out, messages deleted.\r\n")
    assert c.result == Pop3Result(
        "mail", "retr", b"Subject: x\r\n\r\n.dot\r\n##*#read date##*#\r\n", 120
    )
    assert c.wants_close
    first = c.next_event()
    assert first == Pop3Response(True, "POP3 ready")


def test_empty_mailbox() -> None:
    c = check()
    login(c)
    assert feed(c, b"+OK 0 0\r\n") == b"QUIT\r\n"
    feed(c, b"+OK bye\r\n")
    assert c.result is not None and c.result.outcome == "none" and c.wants_close


def test_wrong_password() -> None:
    c = check()
    c.start(0.0)
    feed(c, b"+OK ready\r\n")
    assert feed(c, b"+OK\r\n") == b"PASS secret\r\n"
    assert feed(c, b"-ERR [AUTH] Authentication failed.\r\n") == b"QUIT\r\n"
    assert c.result == Pop3Result(
        "auth_failed", "pass", detail="-ERR [AUTH] Authentication failed."
    )


def test_too_big_is_deleted_unread() -> None:
    c = check(max_size=100)
    login(c)
    feed(c, b"+OK 1 101\r\n")
    assert feed(c, b"+OK 1 101\r\n") == b"DELE 1\r\n"
    assert feed(c, b"+OK\r\n") == b"QUIT\r\n"
    feed(c, b"+OK bye\r\n")
    assert c.result == Pop3Result("too_big", "list", None, 101, "deleted unread")


def test_exactly_max_size_is_retrieved() -> None:
    c = check(max_size=100)
    login(c)
    feed(c, b"+OK 1 100\r\n")
    assert feed(c, b"+OK 1 100\r\n") == b"RETR 1\r\n"


def test_download_over_pop3_time_is_abandoned_without_dele_or_quit() -> None:
    c = check(time_limit=20.0)
    login(c, now=5.0)
    feed(c, b"+OK 1 50\r\n", 5.0)
    assert feed(c, b"+OK 1 50\r\n", 10.0) == b"RETR 1\r\n"
    assert c.deadline == 30.0  # pop3 time, counted from RETR
    assert feed(c, b"+OK\r\nSubject: x\r\n", 29.0) == b""
    assert c.deadline == 30.0  # arriving lines do not extend the download's time
    c.handle_timeout(30.0)
    assert c.result is not None and (c.result.outcome, c.result.stage) == ("timeout", "retr")
    assert "abandoned" in c.result.detail
    assert c.wants_close and c.data_to_send() == b""


def test_connection_lost_before_quit_answer_takes_nothing() -> None:
    c = check()
    login(c)
    feed(c, b"+OK 1 10\r\n")
    feed(c, b"+OK 1 10\r\n")
    feed(c, b"+OK\r\nhi\r\n.\r\n")
    assert feed(c, b"+OK\r\n") == b"QUIT\r\n"
    feed(c, b"")
    assert c.result is not None and c.result.outcome == "broken" and c.result.message is None


def test_err_to_retr_fails_and_quits() -> None:
    c = check()
    login(c)
    feed(c, b"+OK 1 10\r\n")
    feed(c, b"+OK 1 10\r\n")
    assert feed(c, b"-ERR no such message\r\n") == b"QUIT\r\n"
    assert c.result is not None and (c.result.outcome, c.result.stage) == ("failed", "retr")


def test_byte_by_byte() -> None:
    c = check()
    c.start(0.0)
    script = (
        b"+OK hi\r\n+OK\r\n+OK\r\n+OK 1 9\r\n+OK 1 9\r\n+OK\r\na\r\n..b\r\n.\r\n+OK\r\n+OK bye\r\n"
    )
    sent = b""
    for i in range(len(script)):
        c.receive_data(script[i : i + 1], 1.0)
        sent += c.data_to_send()
    assert sent == (
        b"USER logger@example.net\r\nPASS secret\r\nSTAT\r\nLIST 1\r\nRETR 1\r\nDELE 1\r\nQUIT\r\n"
    )
    assert c.result is not None and c.result.message == b"a\r\n.b\r\n"


def test_not_pop3_is_broken() -> None:
    c = check()
    c.start(0.0)
    feed(c, b"220 smtp.example.net ESMTP\r\n")
    assert c.result is not None and c.result.outcome == "broken"


def test_busy_mailbox_is_not_a_wrong_password() -> None:
    c = check()
    c.start(0.0)
    feed(c, b"+OK ready\r\n")
    feed(c, b"+OK\r\n")
    assert feed(c, b"-ERR [IN-USE] mailbox is open in another session\r\n") == b"QUIT\r\n"
    assert c.result is not None and (c.result.outcome, c.result.stage) == ("failed", "pass")


def test_a_long_line_in_the_mail_is_not_a_broken_server() -> None:
    c = check(max_size=10_000)
    login(c)
    feed(c, b"+OK 1 6002\r\n")
    feed(c, b"+OK 1 6002\r\n")
    feed(c, b"+OK\r\n" + b"x" * 5000)
    assert c.result is None
    assert feed(c, b"x" * 1000 + b"\r\n.\r\n") == b"DELE 1\r\n"
    feed(c, b"+OK\r\n")
    feed(c, b"+OK\r\n")
    assert c.result is not None and c.result.message == b"x" * 6000 + b"\r\n"
