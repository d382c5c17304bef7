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

from sondalog.client.phone import PhoneApi, PhoneApiError
from sondalog.config import of
from sondalog.io.serial_ports import serial_8n1

from .modem_sms import Conversation, ModemError, one_sms
from .outbox import Message
from .rules import Notify
from .senders import DeliveryError, Sender, register_sender

log = logging.getLogger(__name__)

#: How long opening the serial line may take.
OPEN_TIMEOUT = 5.0


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


def create(notify: Notify) -> Sender:
    t = of(notify.settings, where=f"notify.{notify.name}")
    numbers = tuple(t.texts("number"))
    if t.text("via") == "network":
        return NetworkSms(t.text("url"), t.text("from"), numbers)
    return ModemSms(str(t.path("device")), t.integer("baud", 9600), numbers)


register_sender("sms", create)
