"""Properties: any message survives our POP3 server core -> the logger's POP3 core, and the
SMTP core's dot-stuffing, byte for byte (with CRLF line ends), fed in any chunking."""

from __future__ import annotations

from collections.abc import Sequence

from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.protocol.pop3_client import Pop3Check
from sondalog.protocol.pop3_server import DropEntry, Maildrop, Pop3Session, crlf
from sondalog.protocol.smtp_client import dot_stuff

lines = st.lists(
    st.one_of(
        st.sampled_from([b"", b".", b"..", b".x", b"x.", b" .", b"\r"]),
        st.binary(max_size=40).map(lambda b: b.replace(b"\r", b"").replace(b"\n", b"")),
    ),
    max_size=30,
)
endings = st.sampled_from([b"\r\n", b"\n", b"\r"])


class OneMessage:
    def __init__(self, message: bytes) -> None:
        self.message = message
        self.deleted: list[str] = []

    def open(self, user: str, password: str) -> Maildrop | None:
        return self if (user, password) == ("u", "p") else None

    def entries(self) -> Sequence[DropEntry]:
        return [DropEntry("k", len(crlf(self.message)))]

    def content(self, index: int) -> bytes:
        return self.message

    def commit(self, deleted: Sequence[str]) -> None:
        self.deleted.extend(deleted)

    def release(self) -> None:
        pass


def converse(server: Pop3Session, client: Pop3Check, chunk: int) -> None:
    server.start(0.0)
    client.start(0.0)
    for _ in range(1000):
        down = server.data_to_send()
        for i in range(0, len(down), chunk):
            client.receive_data(down[i : i + chunk], 1.0)
        up = client.data_to_send()
        for i in range(0, len(up), chunk):
            server.receive_data(up[i : i + chunk], 1.0)
        if not down and not up:
            break


@settings(max_examples=150, deadline=None)
@given(lines, endings, st.integers(min_value=1, max_value=64))
def test_pop3_cores_carry_any_message(body: list[bytes], end: bytes, chunk: int) -> None:
    message = end.join(body)
    store = OneMessage(message)
    server = Pop3Session(store)
    client = Pop3Check("u", "p", max_size=100_000, time_limit=10.0)
    converse(server, client, chunk)
    assert client.result is not None and client.result.outcome == "mail"
    assert client.result.message == crlf(message)
    assert client.wants_close and server.wants_close
    assert store.deleted == ["k"]


@settings(max_examples=200, deadline=None)
@given(lines, endings)
def test_dot_stuffing_undoes_to_crlf_text(body: list[bytes], end: bytes) -> None:
    message = end.join(body)
    stuffed = dot_stuff(message)
    assert stuffed.endswith(b".\r\n")
    payload = stuffed[: -len(b".\r\n")].split(b"\r\n")[:-1] if stuffed != b".\r\n" else []
    assert all(not ln.startswith(b".") or ln.startswith(b"..") for ln in payload)
    undone = b"".join((ln[1:] if ln.startswith(b".") else ln) + b"\r\n" for ln in payload)
    assert undone == crlf(message)
