"""The logger's e-mail through its modem to the real mail hub (aiosmtpd SMTP, our POP3 over
Maildirs) on loopback TCP: the pure world on a stepped clock, its IP gateway served by real
asyncio connections."""

from __future__ import annotations

import asyncio
import mailbox
from pathlib import Path

from gsm_world import World

from sondalog.ala1.outbox import Destination
from sondalog.app.mailhub import MailHub, MailHubConfig
from sondalog.gsm.gateway import (
    Close,
    Closed,
    Connect,
    Connected,
    ConnectFailed,
    IpEffect,
    Received,
    Send,
)

ACCOUNTS = {"logger@example.net": "secret", "user@example.net": "secret"}
COMMAND = b"From: user@example.net\r\nSubject: cmd\r\n\r\nplease ##*#read com speed##*#\r\n"


class RealIp:
    """Serves the world's gateway effects with real TCP connections."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.writers: dict[int, asyncio.StreamWriter] = {}
        self.tasks: set[asyncio.Task[None]] = set()
        world.serve = self.serve  # type: ignore[method-assign]

    def serve(self, effect: IpEffect) -> None:
        if isinstance(effect, Connect):
            task = asyncio.get_running_loop().create_task(self._connect(effect))
            self.tasks.add(task)
        elif isinstance(effect, Send) and effect.conn in self.writers:
            self.writers[effect.conn].write(effect.data)
        elif isinstance(effect, Close) and effect.conn in self.writers:
            self.writers.pop(effect.conn).close()

    async def _connect(self, effect: Connect) -> None:
        try:
            reader, writer = await asyncio.open_connection(effect.host, effect.port)
        except OSError:
            self.world.event(ConnectFailed(effect.conn))
            return
        self.writers[effect.conn] = writer
        self.world.event(Connected(effect.conn))
        while data := await reader.read(65536):
            self.world.event(Received(effect.conn, data))
        if self.writers.pop(effect.conn, None) is not None:
            self.world.event(Closed(effect.conn))


def test_message_by_email_then_the_mailed_command_answered(tmp_path: Path) -> None:
    async def main() -> None:
        hub = MailHub(MailHubConfig(tmp_path, ACCOUNTS, smtp_port=0, pop3_port=0))
        async with hub:
            w = World(
                "wavecom41",
                f"write com network smtp address smtp.example.net:{hub.smtp_port}",
                "write com network pop3 address "
                f"logger@example.net:secret@pop3.example.net:{hub.pop3_port}",
                "write email send from logger@example.net",
                "write email send subject ALA1",
            )
            w.network.gateway.hosts.update(
                {"smtp.example.net": "127.0.0.1", "pop3.example.net": "127.0.0.1"}
            )
            RealIp(w)
            hub.accounts.deliver("logger@example.net", COMMAND)
            ident = w.send("row 1\r\nOK\r\n", Destination("email", "user@example.net"))
            inbox = mailbox.Maildir(hub.maildir("user@example.net"), factory=None)
            for _ in range(2000):
                w.run(0.05)
                await asyncio.sleep(0.002)
                if len(inbox) >= 2 and not w.driver.busy and w.driver._job is None:
                    break
            assert (ident, True) in w.done
            bodies = sorted(m.get_payload() for m in inbox)
            assert bodies == ["9600\nOK\n", "row 1\nOK\n"]
            assert all(m["From"] == "logger@example.net" for m in inbox)
            assert len(mailbox.Maildir(hub.maildir("logger@example.net"), factory=None)) == 0

    asyncio.run(asyncio.wait_for(main(), 60))
