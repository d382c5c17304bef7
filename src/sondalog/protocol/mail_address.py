"""Mail server specifications and e-mail address values of the ALA1 (pure).

- ``com network smtp address`` (§6.11.6.3): ``[user:password@]host[:port]``, port 25 when
  absent.
- ``com network pop3 address`` (§6.11.6.4.1): ``user:password@host[:port]``, port 110 when
  absent. The user name may itself hold ``@`` (the manual's example
  ``jan.novak@posta.cz:heslo@pop3.posta.cz``), so the credentials end at the LAST ``@``; the
  user name ends at the FIRST ``:`` of the credentials (a password may hold ``:``).
- An ``email`` address value (§6.10.3) may carry its own SMTP server after one more ``@``:
  ``MyALA@ala1.com@user:password@smtp.host:2525``; that server wins over
  ``com network smtp address``.

Every malformed text raises :class:`MailAddressError` with a message fit for a user.
"""

from __future__ import annotations

from dataclasses import dataclass

SMTP_PORT = 25
POP3_PORT = 110


class MailAddressError(ValueError):
    """A server specification or an e-mail address value that cannot be used."""


@dataclass(frozen=True)
class MailServer:
    """Where to connect and, when given, the credentials to log in with."""

    host: str
    port: int
    user: str | None = None
    password: str | None = None

    @property
    def has_credentials(self) -> bool:
        return self.user is not None

    def __str__(self) -> str:
        """The spec again, with the password hidden (for logs and messages)."""
        cred = f"{self.user}:***@" if self.user is not None else ""
        return f"{cred}{self.host}:{self.port}"


def _host_port(text: str, default_port: int, whole: str) -> tuple[str, int]:
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port = text, default_port
    else:
        if not port_text.isdigit() or not 0 < int(port_text) < 65536:
            raise MailAddressError(f"bad port {port_text!r} in {whole!r}")
        port = int(port_text)
    if not host or any(c.isspace() or c in "@:/" for c in host):
        raise MailAddressError(f"bad server host name {host!r} in {whole!r}")
    return host, port


def parse_server(text: str, default_port: int, *, need_credentials: bool = False) -> MailServer:
    """Parse ``[user:password@]host[:port]`` (§6.11.6.3, §6.11.6.4.1)."""
    spec = text.strip()
    if not spec:
        raise MailAddressError("no server given")
    cred, at, hostport = spec.rpartition("@")
    host, port = _host_port(hostport, default_port, spec)
    if not at:
        if need_credentials:
            raise MailAddressError(f"{spec!r} lacks user:password@ before the server")
        return MailServer(host, port)
    user, colon, password = cred.partition(":")
    if not colon or not user:
        raise MailAddressError(f"credentials in {spec!r} must be user:password")
    return MailServer(host, port, user, password)


def parse_smtp_server(text: str) -> MailServer:
    """``com network smtp address`` (§6.11.6.3): credentials optional, port 25."""
    return parse_server(text, SMTP_PORT)


def parse_pop3_server(text: str) -> MailServer:
    """``com network pop3 address`` (§6.11.6.4.1): credentials required, port 110."""
    return parse_server(text, POP3_PORT, need_credentials=True)


def check_address(text: str) -> str:
    """A plain ``local@domain`` address (no display name), stripped; raises when not one."""
    addr = text.strip()
    local, at, domain = addr.partition("@")
    bad = set(' \t\r\n<>()[],;:\\"')
    if not at or not local or not domain or "@" in domain or bad & set(addr):
        raise MailAddressError(f"{text!r} is not an e-mail address")
    return addr


def split_email_value(value: str) -> tuple[str, str | None]:
    """``addr@domain[@server]`` cut after its second ``@``, unchecked; ``None``: no server."""
    local, at1, rest = value.partition("@")
    domain, at2, server = rest.partition("@")
    return f"{local}{at1}{domain}", server if at2 else None


def parse_email_value(text: str) -> tuple[str, MailServer | None]:
    """An ``email`` address value (§6.10.3): the address and its own SMTP server, if any."""
    address, server = split_email_value(text.strip())
    address = check_address(address)
    if server is None:
        return address, None
    return address, parse_smtp_server(server)
