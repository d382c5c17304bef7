"""The collector's alarms for a message source (issue 21): a mailbox that answers while its
logger is silent (a GSM logger out of coverage) is not a contact with the logger."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from sondalog.collect.alarm_loop import AlarmLoop
from sondalog.collect.config import load_config
from sondalog.collect.model import Reading
from sondalog.collect.store_sqlite import SqliteStore

CONFIG = """\
[sqlite]
path = "c.sqlite"

[[source]]
name = "gsm-mail"
kind = "mailbox"
url = "pop3://user:secret@127.0.0.1:1"
logger = "000003"
interval = 10

[[alarm]]
name = "silent"
kind = "no_contact"
after = 100
"""


def _states(loop: AlarmLoop) -> dict[str, str]:
    return {r.rule: r.state for r in loop.alarms.export()}


def test_a_mailbox_without_messages_raises_no_contact_and_a_message_clears_it(
    tmp_path: Path,
) -> None:
    path = tmp_path / "collector.toml"
    path.write_text(CONFIG)
    config = load_config(path)
    now = [1_700_000_000.0]
    sqlite = SqliteStore(config.store).open_sync()
    loop = AlarmLoop(config, clock=lambda: now[0])
    loop.open(sqlite, config.sources)
    try:
        for _ in range(12):  # the mailbox answers every 10 s, with nothing in it
            now[0] += 10
            loop.contact_started("gsm-mail")
            loop.contact("gsm-mail", ok=True)
            loop.turn(now[0])
        assert _states(loop) == {"silent": "raised"}
        now[0] += 10
        loop.contact_started("gsm-mail")  # the logger is back: its held rows arrive
        row = Reading("000003", 1, datetime(2026, 1, 1), 0, 0, 1.5)
        loop.readings("gsm-mail", [row])
        loop.contact("gsm-mail", ok=True)
        assert _states(loop) == {"silent": "cleared"}
    finally:
        loop.store.close()
        sqlite.close_sync()
