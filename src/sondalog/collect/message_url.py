"""The URLs of the message sources: ``pop3://USER:PASSWORD@HOST:PORT`` and ``http://HOST:PORT``.

The user of a POP3 mailbox is usually an address (``user@example.net``): the last ``@`` of the
URL ends the credentials. Characters a URL cannot hold raw may be %-escaped.
"""

from __future__ import annotations

from dataclasses import dataclass
from urllib.parse import unquote, urlsplit


@dataclass(frozen=True, slots=True)
class Pop3Url:
    host: str
    port: int
    user: str
    password: str


def parse_pop3_url(url: str) -> Pop3Url:
    """``pop3://user@example.net:secret@127.0.0.1:1110``; raises ValueError."""
    parts = urlsplit(url)
    if parts.scheme != "pop3":
        raise ValueError(f"a mailbox URL is pop3://USER:PASSWORD@HOST:PORT, not {url!r}")
    if not parts.hostname or parts.username is None or parts.password is None:
        raise ValueError("a mailbox URL needs USER:PASSWORD@HOST (pop3://USER:PASSWORD@HOST:PORT)")
    try:
        port = parts.port or 110
    except ValueError:
        raise ValueError(f"bad port in {url!r}") from None
    return Pop3Url(parts.hostname, port, unquote(parts.username), unquote(parts.password))


def check_message_url(kind: str, url: str) -> None:
    """Raise ValueError when ``url`` is not one a ``kind`` source can read."""
    if kind == "mailbox":
        parse_pop3_url(url)
        return
    parts = urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ValueError(f"a network source's URL is the GSM API's http://HOST:PORT, not {url!r}")
