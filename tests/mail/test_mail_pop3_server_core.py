"""The pure POP3 server session against scripted client lines (byte-exact).

The store here is a small in-memory maildrop (the Maildir one is tested over TCP with
``poplib`` in test_mail_hub.py)."""

from __future__ import annotations

from collections.abc import Sequence

from sondalog.protocol.pop3_server import DropEntry, Maildrop, MaildropBusy, Pop3Session, crlf

MESSAGES = {
    "uid-a": b"Subject: one\n\nbody\n.starts with a dot\n",
    "uid-b": b"Subject: two\r\nX: y\r\n\r\nl1\r\nl2\r\nl3\r\n",
}


class MemoryDrop:
    def __init__(self, store: MemoryStore) -> None:
        self.store = store
        self.uids = list(store.messages)

    def entries(self) -> Sequence[DropEntry]:
        return [DropEntry(u, len(crlf(self.store.messages[u]))) for u in self.uids]

    def content(self, index: int) -> bytes:
        return self.store.messages[self.uids[index]]

    def commit(self, deleted: Sequence[str]) -> None:
        if self.store.fail_commit:
            raise OSError("disk gone")
        for uid in deleted:
            del self.store.messages[uid]

    def release(self) -> None:
        self.store.open_now = False


class MemoryStore:
    def __init__(self) -> None:
        self.messages = dict(MESSAGES)
        self.open_now = False
        self.fail_commit = False

    def open(self, user: str, password: str) -> Maildrop | None:
        if (user, password) != ("alice", "pass word"):
            return None
        if self.open_now:
            raise MaildropBusy(user)
        self.open_now = True
        return MemoryDrop(self)


def session(store: MemoryStore | None = None) -> tuple[Pop3Session, MemoryStore]:
    store = store or MemoryStore()
    s = Pop3Session(store, timeout=600.0)
    s.start(0.0)
    assert s.data_to_send() == b"+OK sondalog POP3 server ready\r\n"
    return s, store


def say(s: Pop3Session, line: bytes, now: float = 1.0) -> bytes:
    s.receive_data(line + b"\r\n", now)
    return s.data_to_send()


def logged_in() -> tuple[Pop3Session, MemoryStore]:
    s, store = session()
    assert say(s, b"USER alice") == b"+OK send PASS\r\n"
    assert say(s, b"PASS pass word") == b"+OK logged in, 2 messages (76 octets)\r\n"
    return s, store


def test_capa_before_login() -> None:
    s, _ = session()
    assert say(s, b"capa") == (
        b"+OK capability list follows\r\nUSER\r\nUIDL\r\nTOP\r\nRESP-CODES\r\n"
        b"PIPELINING\r\nIMPLEMENTATION sondalog\r\n.\r\n"
    )


def test_wrong_password_and_commands_before_login() -> None:
    s, _ = session()
    assert say(s, b"STAT") == b"-ERR command 'STAT' not valid before login\r\n"
    assert say(s, b"PASS x") == b"-ERR PASS needs USER name then PASS password\r\n"
    say(s, b"USER alice")
    assert say(s, b"PASS wrong") == b"-ERR [AUTH] invalid user name or password\r\n"
    assert say(s, b"PASS pass word") == b"-ERR PASS needs USER name then PASS password\r\n"
    say(s, b"USER alice")
    assert say(s, b"PASS pass word").startswith(b"+OK logged in")


def test_stat_list_uidl() -> None:
    s, _ = logged_in()
    assert say(s, b"STAT") == b"+OK 2 76\r\n"
    assert say(s, b"LIST") == b"+OK 2 messages (76 octets)\r\n1 42\r\n2 34\r\n.\r\n"
    assert say(s, b"LIST 2") == b"+OK 2 34\r\n"
    assert say(s, b"LIST 3") == b"-ERR no such message: '3'\r\n"
    assert say(s, b"UIDL") == b"+OK\r\n1 uid-a\r\n2 uid-b\r\n.\r\n"
    assert say(s, b"UIDL 1") == b"+OK 1 uid-a\r\n"


def test_retr_stuffs_dots_and_top_cuts_the_body() -> None:
    s, _ = logged_in()
    assert say(s, b"RETR 1") == (
        b"+OK 42 octets\r\nSubject: one\r\n\r\nbody\r\n..starts with a dot\r\n.\r\n"
    )
    head = b"+OK top of message follows\r\nSubject: two\r\nX: y\r\n\r\n"
    assert say(s, b"TOP 2 1") == head + b"l1\r\n.\r\n"
    assert say(s, b"TOP 2 0") == head + b".\r\n"
    assert say(s, b"TOP 2 x") == b"-ERR TOP needs a number of lines\r\n"


def test_dele_rset_and_deletion_only_at_quit() -> None:
    s, store = logged_in()
    assert say(s, b"DELE 1") == b"+OK message 1 deleted\r\n"
    assert say(s, b"DELE 1") == b"-ERR message 1 already deleted\r\n"
    assert say(s, b"RETR 1") == b"-ERR message 1 already deleted\r\n"
    assert say(s, b"STAT") == b"+OK 1 34\r\n"
    assert say(s, b"LIST") == b"+OK 1 messages (34 octets)\r\n2 34\r\n.\r\n"
    assert say(s, b"RSET") == b"+OK maildrop has 2 messages (76 octets)\r\n"
    say(s, b"DELE 2")
    assert "uid-b" in store.messages
    assert say(s, b"NOOP") == b"+OK\r\n"
    assert say(s, b"QUIT") == b"+OK bye, 1 messages deleted\r\n"
    assert s.wants_close and list(store.messages) == ["uid-a"] and not store.open_now


def test_dropped_connection_and_autologout_delete_nothing() -> None:
    s, store = logged_in()
    say(s, b"DELE 1")
    s.receive_data(b"", 2.0)
    assert s.wants_close and len(store.messages) == 2 and not store.open_now
    s, store = logged_in()
    say(s, b"DELE 1", now=10.0)
    assert s.deadline == 610.0
    s.handle_timeout(609.0)
    assert not s.wants_close
    s.handle_timeout(610.0)
    assert s.wants_close and len(store.messages) == 2 and not store.open_now


def test_mailbox_in_use_and_failed_update() -> None:
    s1, store = logged_in()
    s2, _ = session(store)
    say(s2, b"USER alice")
    assert say(s2, b"PASS pass word") == b"-ERR [IN-USE] mailbox is open in another session\r\n"
    store.fail_commit = True
    say(s1, b"DELE 1")
    assert say(s1, b"QUIT") == b"-ERR [SYS/TEMP] some deleted messages not removed\r\n"
    assert s1.wants_close and not store.open_now


def test_bad_lines() -> None:
    s, _ = logged_in()
    assert say(s, b"XTND foo") == b"-ERR unknown command or bad arguments: 'XTND'\r\n"
    assert say(s, b"RETR") == b"-ERR unknown command or bad arguments: 'RETR'\r\n"
    assert say(s, b"RETR -1") == b"-ERR no such message: '-1'\r\n"
    assert say(s, b"X" * 2000) == b"-ERR line too long\r\n"
    s.receive_data(b"Y" * 1500, 1.0)
    assert s.data_to_send() == b"-ERR line too long\r\n"
    assert say(s, b"STAT") == b"+OK 2 76\r\n"


def test_pipelined_commands_in_one_chunk() -> None:
    s, _ = session()
    s.receive_data(b"USER alice\r\nPASS pass word\r\nSTAT\r\nQUIT\r\n", 1.0)
    assert s.data_to_send() == (
        b"+OK send PASS\r\n+OK logged in, 2 messages (76 octets)\r\n+OK 2 76\r\n"
        b"+OK bye, 0 messages deleted\r\n"
    )
