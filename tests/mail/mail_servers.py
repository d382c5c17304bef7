"""Real mail servers for the mail tests: our hub, plain aiosmtpd, Debian's dovecot.

Dovecot follows recipes.md §3: the master runs as root with a private config, mail processes
as ``nobody``, in a 0755 temp dir under /tmp; stopped by its PID."""

from __future__ import annotations

import asyncio
import mailbox
import os
import pwd
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Awaitable, Iterator
from contextlib import contextmanager
from email.message import EmailMessage
from pathlib import Path
from typing import TypeVar

import pytest

from sondalog.app.mailhub import MailHub, MailHubConfig

T = TypeVar("T")

LOGGER = "logger@example.net"
USER = "user@example.net"
PASSWORD = "secret"
ACCOUNTS = {LOGGER: PASSWORD, USER: PASSWORD}
DOVECOT = "/usr/sbin/dovecot"


def run(coro: Awaitable[T], timeout: float = 30.0) -> T:
    async def bounded() -> T:
        return await asyncio.wait_for(coro, timeout)

    return asyncio.run(bounded())


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def wait_port(port: int, timeout: float = 10.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            return
        except OSError:
            time.sleep(0.05)
    raise TimeoutError(port)


def hub(root: Path) -> MailHub:
    return MailHub(MailHubConfig(root, ACCOUNTS, smtp_port=0, pop3_port=0))


def command_mail(
    body: str = "Dobrý den,\n##*#read date##*#\ndíky", sender: str = USER
) -> EmailMessage:
    msg = EmailMessage()
    msg["From"] = sender
    msg["To"] = LOGGER
    msg["Subject"] = "příkaz"
    msg.set_content(body)
    return msg


def maildir_count(path: Path) -> int:
    md = mailbox.Maildir(path, factory=None, create=False)
    try:
        return len(md)
    finally:
        md.close()


class Dovecot:
    """A running dovecot POP3 server with one account ``logger@example.net``."""

    def __init__(self, root: Path, port: int) -> None:
        self.root = root
        self.port = port
        nobody = pwd.getpwnam("nobody")
        self._owner = (nobody.pw_uid, nobody.pw_gid)

    @property
    def maildir(self) -> Path:
        return self.root / "mail" / LOGGER

    def put(self, raw: bytes) -> None:
        md = mailbox.Maildir(self.maildir, factory=None, create=True)
        md.add(raw)
        md.close()
        self.chown()

    def chown(self) -> None:
        subprocess.run(
            ["chown", "-R", f"{self._owner[0]}:{self._owner[1]}", str(self.root / "mail")],
            check=True,
        )

    def clear(self) -> None:
        md = mailbox.Maildir(self.maildir, factory=None, create=True)
        md.clear()
        md.close()

    def log(self) -> str:
        path = self.root / "dovecot.log"
        return path.read_text(errors="replace") if path.exists() else ""


@contextmanager
def dovecot() -> Iterator[Dovecot]:
    if not os.path.exists(DOVECOT):
        pytest.skip(f"{DOVECOT} is absent (Debian package dovecot-pop3d)")
    if os.geteuid() != 0:
        pytest.skip("dovecot's master must start as root (recipes.md §3)")
    d = Path(tempfile.mkdtemp(prefix="sondalog-dovecot-"))
    try:
        os.chmod(d, 0o755)
        nobody = pwd.getpwnam("nobody")
        port = free_port()
        (d / "passwd").write_text(
            f"{LOGGER}:{{PLAIN}}{PASSWORD}:{nobody.pw_uid}:{nobody.pw_gid}::{d}/home/logger::\n"
        )
        (d / "dovecot.conf").write_text(
            f"""base_dir = {d}/run
state_dir = {d}/state
log_path = {d}/dovecot.log
protocols = pop3
listen = 127.0.0.1
ssl = no
disable_plaintext_auth = no
auth_mechanisms = plain login
auth_failure_delay = 0
mail_location = maildir:{d}/mail/%u
pop3_uidl_format = %08Xu%08Xv
passdb {{
  driver = passwd-file
  args = {d}/passwd
}}
userdb {{
  driver = passwd-file
  args = {d}/passwd
}}
service pop3-login {{
  inet_listener pop3 {{
    address = 127.0.0.1
    port = {port}
  }}
}}
"""
        )
        (d / "mail").mkdir()
        server = Dovecot(d, port)
        server.clear()
        server.chown()
        proc = subprocess.Popen(
            [DOVECOT, "-F", "-c", str(d / "dovecot.conf")],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            wait_port(port)
            yield server
        finally:
            proc.terminate()
            proc.wait(10)
    finally:
        shutil.rmtree(d, ignore_errors=True)
