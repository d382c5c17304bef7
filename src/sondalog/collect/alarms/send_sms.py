"""SMS notifications (``[[notify]] kind = "sms"``, issue 21).

- ``via = "network"``: the GSM network's HTTP API (``POST /sms`` from the phone ``from`` to
  every ``number``, :class:`~sondalog.client.phone.PhoneApi`);
- ``via = "modem"``: a modem on the serial line ``device`` at ``baud`` (8N1), in PDU mode
  like gammu (:mod:`.modem_sms`): the line is opened for each notification and closed
  after it, so a modem unplugged and plugged back works again on the next try. Every step
  has a time limit (5 s a command, 30 s a submission) and the read buffer is bounded.

Either way the text is cut to ONE SMS ending ``...`` (:func:`.modem_sms.one_sms`). A
notification to several numbers is delivered when every number got it; a failure retries
it whole (at least once: a number may get it twice).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from dataclasses import dataclass
from pathlib import Path

from sondalog.client.phone import PhoneApi, PhoneApiError
from sondalog.config import Table
from sondalog.io.serial_ports import serial_8n1

from .durations import HTTP_URL, many_matching
from .modem_sms import Conversation, ModemError, one_sms
from .outbox import Message
from .rules import Notify
from .senders import COMMON_KEYS, DeliveryError, Sender, register_sender

log = logging.getLogger(__name__)

#: How long opening the serial line may take.
OPEN_TIMEOUT = 5.0
_PHONE = r"\+?[0-9]{3,20}"
_NETWORK, _MODEM = {"url", "from"}, {"device", "baud"}


@dataclass(frozen=True, slots=True)
class NetworkSmsSettings:
    """``via = "network"``: the network's HTTP API at ``url``, from the phone ``sender``."""

    url: str
    sender: str  # ``from``
    numbers: tuple[str, ...]  # ``number``


@dataclass(frozen=True, slots=True)
class ModemSmsSettings:
    """``via = "modem"``: the modem on the serial line ``device`` at ``baud``."""

    device: Path
    numbers: tuple[str, ...]  # ``number``
    baud: int = 9600


SmsSettings = NetworkSmsSettings | ModemSmsSettings


def parse(t: Table) -> SmsSettings:
    """An ``sms`` table's own keys (raises ``ConfigError``)."""
    t.keys(COMMON_KEYS | {"via", "number"} | _NETWORK | _MODEM)
    via = t.text("via", choices=("network", "modem"))
    numbers = many_matching(t, "number", _PHONE, "phone numbers like +420700000001")
    if via == "network":
        if wrong := sorted(_MODEM & set(t)):
            raise t.fail(wrong[0], 'is for via = "modem"; via = "network" takes url and from')
        return NetworkSmsSettings(
            url=t.text("url", pattern=HTTP_URL, what="an http:// URL"),
            sender=t.text("from", pattern=_PHONE, what="the phone number the SMS come from"),
            numbers=numbers,
        )
    if wrong := sorted(_NETWORK & set(t)):
        raise t.fail(wrong[0], 'is for via = "network"; via = "modem" takes device and baud')
    return ModemSmsSettings(
        device=t.path("device"),
        numbers=numbers,
        baud=t.integer("baud", 9600, lo=1, what="a baud rate"),
    )


def sms_text(message: Message) -> str:
    """What the SMS says: the message's text (a summary's title first), cut to one SMS."""
    text = message.text
    if message.what == "summary":
        text = f"{message.items} alarm notifications: {text}"
    elif message.what == "cleared":
        text = f"CLEARED: {text}"
    else:
        text = f"ALARM: {text}"
    return one_sms(text)[0]


class NetworkSms:
    """SMS through the network's HTTP API at ``url``."""

    def __init__(self, url: str, sender: str, numbers: tuple[str, ...]) -> None:
        self.api = PhoneApi(url)
        self.sender = sender
        self.numbers = numbers

    async def send(self, message: Message) -> None:
        text = sms_text(message)
        for number in self.numbers:
            try:
                await asyncio.to_thread(self.api.sms, self.sender, number, text)
            except PhoneApiError as exc:
                raise DeliveryError(f"SMS to {number}: {exc.message}") from None

    async def close(self) -> None:
        return None


class ModemSms:
    """SMS through the modem on ``device``; one conversation at a time."""

    def __init__(self, device: str, baud: int, numbers: tuple[str, ...]) -> None:
        self.device = device
        self.baud = baud
        self.numbers = numbers
        self._lock = asyncio.Lock()
        #: The message references the modem gave to the SMS sent so far (tests, logs).
        self.references: list[int] = []

    async def send(self, message: Message) -> None:
        async with self._lock:
            try:
                refs = await self._converse(Conversation(self.numbers, sms_text(message)))
            except ModemError as exc:
                raise DeliveryError(f"modem {self.device}: {exc}") from None
            except (OSError, ImportError) as exc:
                raise DeliveryError(f"modem {self.device}: {exc}") from None
        self.references += refs
        log.info("alarm SMS %s sent by modem %s (references %s)", message.key, self.device, refs)

    async def _converse(self, talk: Conversation) -> list[int]:
        import serial_asyncio_fast  # imported here: only modem destinations need it

        try:
            reader, writer = await asyncio.wait_for(
                serial_asyncio_fast.open_serial_connection(
                    url=self.device,
                    baudrate=self.baud,
                    **serial_8n1(),  # type: ignore[arg-type]
                ),
                OPEN_TIMEOUT,
            )
        except TimeoutError:
            raise ModemError(f"the line did not open in {OPEN_TIMEOUT:g} s") from None
        try:
            writer.write(talk.start())
            deadline = time.monotonic() + talk.timeout
            while not talk.done:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise ModemError(f"{talk.step}: no answer in {talk.timeout:g} s")
                try:
                    data = await asyncio.wait_for(reader.read(1024), left)
                except TimeoutError:
                    continue
                if not data:
                    raise ModemError(f"{talk.step}: the line closed")
                step = talk.step
                out = talk.receive(data)
                if out:
                    writer.write(out)
                if talk.step != step or out:
                    deadline = time.monotonic() + talk.timeout
            return talk.references
        finally:
            writer.close()
            with contextlib.suppress(Exception):
                await asyncio.wait_for(writer.wait_closed(), 1.0)

    async def close(self) -> None:
        return None


def create(notify: Notify[SmsSettings]) -> Sender:
    s = notify.settings
    if isinstance(s, NetworkSmsSettings):
        return NetworkSms(s.url, s.sender, s.numbers)
    return ModemSms(str(s.device), s.baud, s.numbers)


register_sender("sms", create, parse)
