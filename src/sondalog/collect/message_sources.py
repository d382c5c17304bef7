"""The collector's message sources: loggers' data messages by e-mail and by SMS (§6.14, §6.8.4.1).

- ``mailbox``: a POP3 mailbox (``pop3://USER:PASSWORD@HOST:PORT``) the loggers send their
  messages to. Each contact reads every mail; a mail is deleted once its rows are committed
  (``keep = true``: left in the mailbox, its UIDL remembered in the source's cursor).
- ``network``: the SMS delivered to ``number`` through the GSM network's HTTP API
  (``GET /sms?to=NUMBER``). A logger sends an answer longer than 160 characters as several
  SMS in order, each full but the last (spec gsm.md §5): the source joins a sender's
  consecutive full SMS with the next shorter one (or one ending ``OK``) into one message; a
  part whose rest has not arrived yet waits for it (concatenated SMS with a user data header
  come joined from the API already). The ids handled are the source's cursor.

Each message goes through :func:`~sondalog.collect.message_rows.parse_message` (the
download's row parser) and :func:`~sondalog.collect.message_rows.identify`, and its readings
go to the same ``deliver`` as a download's (idempotent on (logger, time, counter, channel)).
A message that is not rows, or whose logger is unknown, is skipped with a ``message`` event;
nothing of it is stored.
"""

from __future__ import annotations

import asyncio
import email
import email.policy
import email.utils
import json
import logging
import poplib
from collections.abc import Iterable
from typing import Any
from urllib.parse import quote

from sondalog.client.phone import PhoneApi
from sondalog.client.records import Channel, split_name
from sondalog.collect.config import SourceConfig
from sondalog.collect.delivery import GSM_TYPES, Deliver
from sondalog.collect.message_rows import MessageError, identify, parse_message
from sondalog.collect.message_url import parse_pop3_url
from sondalog.collect.readings import rows_to_readings
from sondalog.collect.store_sqlite import SqliteStore, now_text

log = logging.getLogger(__name__)
#: A logger splits a longer answer into SMS of this many characters, in order (gsm.md §5).
SMS_LENGTH = 160


class MessageIntake:
    """What both message sources share: one message's text -> readings delivered."""

    def __init__(self, config: SourceConfig, store: SqliteStore) -> None:
        self.config = config
        self.store = store
        self.stored = self.skipped = 0

    async def take(self, deliver: Deliver, sender: str, body: str, cursor: str | None) -> bool:
        """Deliver the readings of one message (with ``cursor``); False: skipped (an event
        says why; the cursor still moves on, so a bad message is not read again)."""
        cfg = self.config
        try:
            message = parse_message(body)
        except MessageError as exc:
            return await self._skip(deliver, cursor, f"message from {sender} skipped: {exc}")
        logger = identify(message, sender, cfg.loggers, cfg.logger)
        if logger is None:
            text = (
                f"message from {sender} skipped: unknown logger (give the source "
                "logger = SNUMBER, or map the sender in loggers)"
            )
            return await self._skip(deliver, cursor, text)
        channels, types = self._channels(logger)
        batch = rows_to_readings(message.rows, logger, channels, cfg.zone)
        latest = {GSM_TYPES[types[r.channel]]: r.value for r in batch if r.channel in types}
        await deliver(cfg.name, batch, cursor, logger=logger, last_contact=now_text(), **latest)
        self.store.event(
            cfg.name,
            "message",
            f"message from {sender}: logger {logger}, {len(message.rows)} rows, "
            f"{len(batch)} readings ({message.rows[0].key} .. {message.rows[-1].key})",
        )
        self.stored += 1
        return True

    async def _skip(self, deliver: Deliver, cursor: str | None, text: str) -> bool:
        log.warning("%s: %s", self.config.name, text)
        self.store.event(self.config.name, "message", text)
        await deliver(self.config.name, [], cursor)
        self.skipped += 1
        return False

    def _channels(self, logger: str) -> tuple[dict[int, Channel], dict[int, int]]:
        """Names and units a download stored for ``logger`` (asked of the logger), else the
        source's ``channels`` (then written to the store's ``channels`` table, so that the
        dashboard shows them too), and its GSM channels' types."""
        rows = self.store.db.execute(
            "SELECT channel, name, unit, type FROM channels WHERE logger = ?", (logger,)
        ).fetchall()
        channels = {n: Channel(name, unit) for n, name, unit, _ in rows if name}
        types = {n: t for n, _, _, t in rows if t in GSM_TYPES}
        if not types:  # no download told the store: the source's signal and credit
            gsm = ((self.config.signal, 12), (self.config.credit, 11))
            types = {n: t for n, t in gsm if n is not None}
        if not channels and self.config.channels:
            channels = {n: split_name(text) for n, text in self.config.channels.items()}
            stored = {n: t for n, _, _, t in rows if t is not None} | types
            self.store.set_channels(
                logger,
                [(n, c.name, c.unit, stored.get(n)) for n, c in sorted(channels.items())],
            )
        return channels, types

    def summary(self, what: str) -> str:
        text = f"{what}: {self.stored} messages stored, {self.skipped} skipped"
        self.stored = self.skipped = 0
        return text


def _mail_text(raw: bytes) -> tuple[str, str]:
    """(sender, plain-text body) of one mail."""
    mail = email.message_from_bytes(raw, policy=email.policy.default)
    sender = str(mail.get("From", "") or "")
    addresses = email.utils.getaddresses([sender])
    if addresses and addresses[0][1]:
        sender = addresses[0][1]
    part = mail.get_body(("plain",)) if mail.is_multipart() else mail
    if part is None:
        return sender, ""
    payload = part.get_payload(decode=True)
    if not isinstance(payload, bytes):
        return sender, str(part.get_payload())
    return sender, payload.decode(part.get_content_charset() or "latin-1", "replace")


class MailboxSource:
    """A POP3 mailbox of loggers' data messages (stdlib poplib, in a worker thread)."""

    kind = "mailbox"

    def __init__(self, config: SourceConfig, store: SqliteStore) -> None:
        self.config = config
        self.store = store
        self.url = parse_pop3_url(config.url)
        self.intake = MessageIntake(config, store)

    def _open(self) -> poplib.POP3:
        box = poplib.POP3(self.url.host, self.url.port, timeout=self.config.timeout)
        try:
            box.user(self.url.user)
            box.pass_(self.url.password)
        except poplib.error_proto as exc:
            box.close()
            raise OSError(f"POP3 login as {self.url.user} refused: {exc!r}") from None
        return box

    async def poll(self, deliver: Deliver) -> str:
        run = asyncio.to_thread
        box = await run(self._open)
        try:
            listing = await run(box.uidl)
            entries = [line.decode().split() for line in listing[1]]
            uids = {int(n): uid for n, uid in entries}
            seen = set((self.store.cursor(self.config.name) or "").split())
            keep = self.config.keep
            for number, uid in sorted(uids.items()):
                if keep and uid in seen:
                    continue
                raw = b"\r\n".join((await run(box.retr, number))[1])
                sender, body = _mail_text(raw)
                seen.add(uid)
                cursor = " ".join(u for u in uids.values() if u in seen) if keep else None
                await self.intake.take(deliver, sender, body, cursor)
                if not keep:
                    await run(box.dele, number)
            await run(box.quit)  # RFC 1939: the deletions happen now
        finally:
            box.close()
        return self.intake.summary(f"mailbox {self.url.user}: {len(uids)} mails")


class NetworkSource:
    """The SMS delivered to a phone number of the served GSM network (its HTTP API)."""

    kind = "network"

    def __init__(self, config: SourceConfig, store: SqliteStore) -> None:
        self.config = config
        self.store = store
        self.api = PhoneApi(config.url, timeout=config.timeout)
        self.intake = MessageIntake(config, store)

    async def poll(self, deliver: Deliver) -> str:
        number = self.config.number or ""
        listing: Any = await asyncio.to_thread(self.api.request, "GET", f"/sms?to={quote(number)}")
        if not isinstance(listing, list):
            raise OSError(f"the network API at {self.config.url} did not list SMS")
        done = _Handled.load(self.store.cursor(self.config.name))
        listed = [int(s["id"]) for s in listing]
        pending: dict[str, list[dict[str, Any]]] = {}  # sender -> the parts so far
        new = 0
        for sms in sorted(listing, key=lambda s: int(s["id"])):
            if done.has(int(sms["id"])) or "part" in sms:  # a lone part waits for the others
                continue
            sender, text = str(sms.get("from", "?")), str(sms["text"])
            parts = pending.setdefault(sender, [])
            parts.append(sms)
            if len(text) >= SMS_LENGTH and not text.endswith("OK\r\n"):
                continue  # a full part of a longer answer: the next SMS goes on with it
            del pending[sender]
            for part in parts:
                done.add(int(part["id"]))
            new += 1
            body = "".join(str(part["text"]) for part in parts)
            await self.intake.take(deliver, sender, body, done.dump(listed))
        return self.intake.summary(f"SMS to {number}: {new} new")


class _Handled:
    """The SMS ids handled: every id up to ``upto``, and ``above`` it (JSON in the cursor)."""

    def __init__(self, upto: int = 0, above: set[int] | None = None) -> None:
        self.upto = upto
        self.above = above or set()

    @classmethod
    def load(cls, cursor: str | None) -> _Handled:
        if not cursor:
            return cls()
        data = json.loads(cursor)
        return cls(int(data["upto"]), {int(i) for i in data["above"]})

    def has(self, sms_id: int) -> bool:
        return sms_id <= self.upto or sms_id in self.above

    def add(self, sms_id: int) -> None:
        self.above.add(sms_id)

    def dump(self, listed: Iterable[int]) -> str:
        """Compact against the ids the API lists: ``upto`` moves past every handled one."""
        for sms_id in sorted(listed):
            if sms_id <= self.upto:
                continue
            if sms_id not in self.above:
                break
            self.upto = sms_id
        self.above = {i for i in self.above if i > self.upto}
        return json.dumps({"upto": self.upto, "above": sorted(self.above)})
