"""Mail round trips per second: the logger's pure SMTP and POP3 client cores against the
mail hub (aiosmtpd into Maildir, our POP3 server) on loopback, and the pure cores alone.

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_mail.py [--messages N]``.

- core only: one SMTP conversation and one POP3 check replayed from scripted server lines
  (no I/O), per second.
- smtp send: ``send_mail`` (one TCP connection per message, AUTH PLAIN) into the hub.
- pop3 check: ``check_mailbox`` taking the oldest message each time until the box is empty.
- pop3 RETR of a 1 MB message: bytes per second through our POP3 server and the POP3 core.
"""

from __future__ import annotations

import argparse
import asyncio
import tempfile
import time
from pathlib import Path

from sondalog.app.mailhub import MailHub, MailHubConfig
from sondalog.io.mail.client import check_mailbox, send_mail
from sondalog.protocol.mail_address import MailServer
from sondalog.protocol.mail_command import build_mail
from sondalog.protocol.pop3_client import Pop3Check
from sondalog.protocol.smtp_client import SmtpClient

LOGGER, USER, PASSWORD = "logger@example.net", "user@example.net", "secret"
BODY = "read record 10 from lastread shift\r\n" + "2026-11-30 01:00:00 12.5 13.1\r\n" * 10


def core_only(n: int) -> float:
    msg = build_mail(LOGGER, USER, "ALA1", BODY)
    smtp_script = [
        b"220 hi\r\n",
        b"250-mx\r\n250 AUTH PLAIN\r\n",
        b"235 ok\r\n",
        b"250 ok\r\n",
        b"250 ok\r\n",
        b"354 go\r\n",
        b"250 ok\r\n",
        b"221 bye\r\n",
    ]
    pop_script = [b"+OK\r\n", b"+OK\r\n", b"+OK\r\n", b"+OK 1 600\r\n", b"+OK 1 600\r\n"]
    pop_body = b"+OK\r\n" + msg + b".\r\n+OK\r\n+OK\r\n"
    start = time.perf_counter()
    for _ in range(n):
        c = SmtpClient(LOGGER, [USER], msg, user=LOGGER, password=PASSWORD)
        c.start(0.0)
        for line in smtp_script:
            c.receive_data(line, 1.0)
            c.data_to_send()
        p = Pop3Check(LOGGER, PASSWORD, max_size=10_000, time_limit=60)
        p.start(0.0)
        for line in [*pop_script, pop_body]:
            p.receive_data(line, 1.0)
            p.data_to_send()
        assert c.result is not None and c.result.sent
        assert p.result is not None and p.result.outcome == "mail"
    return n / (time.perf_counter() - start)


async def over_tcp(n: int) -> tuple[float, float, float]:
    root = Path(tempfile.mkdtemp(prefix="bench-mail-"))
    accounts = {LOGGER: PASSWORD, USER: PASSWORD}
    async with MailHub(MailHubConfig(root, accounts, smtp_port=0, pop3_port=0)) as hub:
        smtp = MailServer("127.0.0.1", hub.smtp_port, USER, PASSWORD)
        msg = build_mail(USER, LOGGER, "cmd", "##*#read date##*#\r\n" + BODY)
        start = time.perf_counter()
        for _ in range(n):
            assert (await send_mail(smtp, USER, [LOGGER], msg)).sent
        sends = n / (time.perf_counter() - start)
        box = MailServer("127.0.0.1", hub.pop3_port, LOGGER, PASSWORD)
        start = time.perf_counter()
        for _ in range(n):
            got = await check_mailbox(box, max_size=10_000, time_limit=60)
            assert got.outcome == "mail", str(got)
        checks = n / (time.perf_counter() - start)
        big = b"Subject: big\n\n" + (b"0123456789abcdef" * 4 + b"\n") * 16384
        hub.accounts.deliver(LOGGER, big)
        start = time.perf_counter()
        got = await check_mailbox(box, max_size=2_000_000, time_limit=60)
        assert got.outcome == "mail" and got.size is not None, str(got)
        rate = got.size / (time.perf_counter() - start)
    return sends, checks, rate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=int, default=200)
    args = ap.parse_args()
    print(f"pure cores (1 SMTP send + 1 POP3 check): {core_only(args.messages * 10):9.0f} /s")
    sends, checks, rate = asyncio.run(over_tcp(args.messages))
    print(f"smtp send into the hub (TCP, AUTH):      {sends:9.0f} messages/s")
    print(f"pop3 check taking one message (TCP):     {checks:9.0f} checks/s")
    print(f"pop3 RETR of 1 MB:                       {rate / 1e6:9.1f} MB/s")


if __name__ == "__main__":
    main()
