"""MQTT notifications (``[[notify]] kind = "mqtt"``, issue 21): a Home Assistant
``binary_sensor`` per rule and a JSON event per notification.

With ``topic = "sondalog/alarms"`` (the default) and a rule named ``hot``:

- ``homeassistant/binary_sensor/sondalog_alarm_hot/config`` (retained, ``discovery = true``;
  the prefix is ``discovery_prefix``): the sensor, device class ``problem``, sent before the
  rule's first state in each connection;
- ``sondalog/alarms/hot/state`` (retained): ``ON`` while an alarm of the rule is raised (a
  raise or a repeat), ``OFF`` once the last of its subjects this collector saw raised
  clears;
- ``sondalog/alarms/alarm/event`` (not retained): the notification as JSON (the webhook's
  body: ``key``, ``alarm``, ``rule``, ``subject``, ``what``, ``value``, ``time``, ``text``,
  ``items``); a rate-limit summary is only an event;
- ``sondalog/alarms/availability`` (retained): ``online`` while the sender is connected,
  ``offline`` by its last will or when it closes; every sensor names it.

The connection (client id ``sondalog-alarms-<notify name>``) is opened on the first
notification and kept; a failed publish drops it and raises
:class:`~.senders.DeliveryError` (the outbox retries, and the next try reconnects).
Every publish is QoS 1 and waits for the broker's acknowledgement.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import ssl
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote, urlsplit

import aiomqtt

from sondalog.collect.ha_discovery import origin, safe_id
from sondalog.config import Table

from .outbox import Message
from .rules import Notify
from .send_webhook import payload
from .senders import COMMON_KEYS, DeliveryError, Sender, register_sender

ON, OFF = "ON", "OFF"
#: Seconds a connection or a publish may take.
TIMEOUT = 10.0


@dataclass(frozen=True, slots=True)
class MqttSettings:
    """An ``mqtt`` destination's own keys, checked."""

    url: str  # mqtt:// or mqtts://, with user:password@ if the broker wants them
    topic: str = "sondalog/alarms"
    discovery: bool = True
    discovery_prefix: str = "homeassistant"


def parse(t: Table) -> MqttSettings:
    """An ``mqtt`` table's own keys (raises ``ConfigError``)."""
    t.keys(COMMON_KEYS | {"url", "topic", "discovery", "discovery_prefix"})
    return MqttSettings(
        url=t.text("url", pattern=r"mqtts?://\S+", what="an mqtt:// URL"),
        topic=t.text("topic", "sondalog/alarms", pattern=r"[^#+\s]+", what="a topic prefix"),
        discovery=t.flag("discovery", True),
        discovery_prefix=t.text("discovery_prefix", "homeassistant"),
    )


class MqttAlarms:
    """Publishes the alarms of one ``[[notify]]`` destination to a broker."""

    def __init__(
        self,
        name: str,
        url: str,
        topic: str,
        discovery: bool,
        discovery_prefix: str,
    ) -> None:
        parts = urlsplit(url)
        self.tls = parts.scheme == "mqtts"
        self.host = parts.hostname or ""
        self.port = parts.port or (8883 if self.tls else 1883)
        self.username = unquote(parts.username) if parts.username else None
        self.password = unquote(parts.password) if parts.password else None
        self.client_id = f"sondalog-alarms-{safe_id(name)}"
        self.topic = topic.strip("/")
        self.discovery = discovery
        self.discovery_prefix = discovery_prefix.strip("/")
        self._client: aiomqtt.Client | None = None
        self._announced: set[str] = set()
        #: The subjects of each rule seen raised (and not cleared) in this run.
        self.raised: dict[str, set[str]] = {}

    @property
    def availability(self) -> str:
        return f"{self.topic}/availability"

    @property
    def event_topic(self) -> str:
        return f"{self.topic}/alarm/event"

    def node(self, rule: str) -> str:
        return "sondalog_alarm_" + safe_id(rule)

    def state_topic(self, rule: str) -> str:
        return f"{self.topic}/{safe_id(rule)}/state"

    def config_topic(self, rule: str) -> str:
        return f"{self.discovery_prefix}/binary_sensor/{self.node(rule)}/config"

    def discovery_payload(self, rule: str) -> dict[str, Any]:
        """Home Assistant's MQTT discovery config of the rule's ``binary_sensor``."""
        return {
            "name": rule,
            "unique_id": self.node(rule),
            "object_id": self.node(rule),
            "device_class": "problem",
            "state_topic": self.state_topic(rule),
            "payload_on": ON,
            "payload_off": OFF,
            "availability_topic": self.availability,
            "payload_available": "online",
            "payload_not_available": "offline",
            "device": {"identifiers": ["sondalog_alarms"], "name": "sondalog alarms"},
            "origin": origin(),
        }

    def state(self, message: Message) -> str | None:
        """The rule's state after ``message`` (``None``: no rule, or no change to say)."""
        if message.rule is None or message.what == "summary":
            return None
        subjects = self.raised.setdefault(message.rule, set())
        subject = message.subject or ""
        if message.what == "cleared":
            subjects.discard(subject)
            return OFF if not subjects else ON
        subjects.add(subject)
        return ON

    async def _connect(self) -> aiomqtt.Client:
        if self._client is not None:
            return self._client
        client = aiomqtt.Client(
            self.host,
            self.port,
            identifier=self.client_id,
            username=self.username,
            password=self.password,
            will=aiomqtt.Will(self.availability, b"offline", qos=1, retain=True),
            keepalive=30,
            timeout=TIMEOUT,
            tls_context=ssl.create_default_context() if self.tls else None,
        )
        await client.__aenter__()
        try:
            await client.publish(self.availability, b"online", qos=1, retain=True)
        except BaseException:
            with contextlib.suppress(Exception):
                await client.__aexit__(None, None, None)
            raise
        self._client = client
        self._announced.clear()
        return client

    async def send(self, message: Message) -> None:
        try:
            client = await self._connect()
            state = self.state(message)
            if state is not None and message.rule is not None:
                if self.discovery and message.rule not in self._announced:
                    config = json.dumps(self.discovery_payload(message.rule), ensure_ascii=False)
                    await client.publish(
                        self.config_topic(message.rule), config.encode(), qos=1, retain=True
                    )
                    self._announced.add(message.rule)
                await client.publish(
                    self.state_topic(message.rule), state.encode(), qos=1, retain=True
                )
            event = json.dumps(payload(message), ensure_ascii=False).encode()
            await client.publish(self.event_topic, event, qos=1, retain=False)
        except (aiomqtt.MqttError, OSError) as exc:
            await self._drop()
            raise DeliveryError(f"mqtt {self.host}:{self.port}: {exc}") from None

    async def _drop(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(Exception):
                await client.__aexit__(None, None, None)
            # a lost connection's error is in this future: retrieve it (no "never retrieved")
            lost = getattr(client, "_disconnected", None)
            if isinstance(lost, asyncio.Future) and lost.done() and not lost.cancelled():
                lost.exception()

    async def close(self) -> None:
        """Say ``offline`` (a clean disconnect sends no last will) and disconnect."""
        client = self._client
        if client is not None:
            with contextlib.suppress(aiomqtt.MqttError):
                await client.publish(self.availability, b"offline", qos=1, retain=True)
        await self._drop()


def create(notify: Notify[MqttSettings]) -> Sender:
    s = notify.settings
    return MqttAlarms(notify.name, s.url, s.topic, s.discovery, s.discovery_prefix)


register_sender("mqtt", create, parse)
