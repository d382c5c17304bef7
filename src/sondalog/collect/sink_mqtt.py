"""The MQTT sink: readings as retained JSON states, loggers announced to Home Assistant.

Configured by the ``[mqtt]`` table::

    [mqtt]
    url = "mqtt://user:secret@broker:1883"   # mqtts:// for TLS (port 8883 by default)
    prefix = "sondalog"                      # state topics: <prefix>/<node>/ch<n>
    discovery_prefix = "homeassistant"       # Home Assistant's discovery prefix
    client_id = "sondalog-collector"         # unique per collector process on one broker

A background task keeps the connection (its own reconnect loop, backoff 0.2 s doubling up
to 30 s). On every connect it publishes ``online`` (retained) on the availability topic
(the last will publishes ``offline``, and so does a clean close, except after
``collect --once``: runs from cron leave ``online`` between them, docs/decisions.md),
subscribes to ``homeassistant/status`` and sends the device discovery of every logger it
knows; it sends them again whenever Home Assistant says ``online`` there. Payloads:
:mod:`sondalog.collect.ha_discovery`.

:meth:`MqttSink.write` raises :class:`SinkUnavailable` while the broker is away. Readings it
already published (acknowledged by the broker, QoS 1) are remembered by key, so a batch
replayed after a failure halfway publishes only what is missing: nothing twice.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import random
import ssl
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from urllib.parse import SplitResult, unquote, urlsplit

import aiomqtt

from sondalog.collect.ha_discovery import Device, Topics, discovery_payload, state_payload
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.sinks import register_sink
from sondalog.config import Table, of

log = logging.getLogger(__name__)

_KEYS = {"url", "prefix", "discovery_prefix", "client_id"}
_SENT_MAX = 200_000
_WINDOW = 512  # states in flight at once


@dataclass(frozen=True, slots=True)
class MqttConfig:
    host: str
    port: int
    tls: bool
    username: str | None
    password: str | None
    topics: Topics


def _url(url: str) -> tuple[str, int, SplitResult]:
    parts = urlsplit(url)
    if parts.scheme not in ("mqtt", "mqtts") or not parts.hostname:
        raise ValueError(f"{url!r} is not mqtt://host[:port] or mqtts://host[:port]")
    try:
        port = parts.port or (8883 if parts.scheme == "mqtts" else 1883)
    except ValueError as e:
        raise ValueError(f"{url!r}: {e}") from None
    return parts.hostname, port, parts


def parse_config(table: Table) -> MqttConfig:
    """Check the ``[mqtt]`` table (``ConfigError`` names the file, line and field)."""
    table.keys(_KEYS)
    host, port, parts = table.convert("url", _url)
    topics = Topics(
        prefix=table.text("prefix", "sondalog", empty=True).strip("/") or "sondalog",
        discovery=table.text("discovery_prefix", "homeassistant", empty=True).strip("/"),
        client_id=table.text("client_id", "sondalog-collector", empty=True),
    )
    for key, t in (("prefix", topics.prefix), ("discovery_prefix", topics.discovery)):
        if not t or "+" in t or "#" in t:
            raise table.fail(key, f"topic prefix {t!r} must be non-empty without + or #")
    return MqttConfig(
        host=host,
        port=port,
        tls=parts.scheme == "mqtts",
        username=unquote(parts.username) if parts.username else None,
        password=unquote(parts.password) if parts.password else None,
        topics=topics,
    )


class MqttSink:
    """Publishes readings to an MQTT broker (see the module docstring)."""

    name = "mqtt"

    def __init__(self, cfg: MqttConfig, *, publish_timeout: float = 5.0) -> None:
        self.cfg = cfg
        self.topics = cfg.topics
        self.publish_timeout = publish_timeout
        self.devices: dict[str, Device] = {}
        self.connects = 0
        #: ``collect --once`` (cron): a clean close leaves the availability ``online``.
        self.stay_online = False
        self.discoveries_sent = 0
        self._client: aiomqtt.Client | None = None
        self._connected = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._closing = False
        self._unannounced: set[str] = set()  # loggers whose discovery is not yet current
        self._sent: OrderedDict[tuple[str, str, int, int], None] = OrderedDict()

    @property
    def connected(self) -> bool:
        return self._client is not None

    async def wait_connected(self, timeout: float) -> bool:
        try:
            await asyncio.wait_for(self._connected.wait(), timeout)
        except TimeoutError:
            return False
        return True

    async def open(self) -> None:
        """Start the connection loop; wait up to 2 s for a first connection (not required)."""
        if self._task is None:
            self._closing = False
            self._task = asyncio.create_task(self._run(), name="mqtt-sink")
        await self.wait_connected(2.0)

    async def close(self) -> None:
        """Say ``offline`` (a clean disconnect sends no last will), unless :attr:`stay_online`,
        and stop the loop."""
        self._closing = True
        client = self._client
        if client is not None and not self.stay_online:
            with contextlib.suppress(aiomqtt.MqttError):
                await client.publish(self.topics.availability, "offline", qos=1, retain=True)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        self._client = None
        self._connected.clear()

    async def write(self, batch: Sequence[Reading]) -> None:
        client = self._client
        if client is None:
            raise SinkUnavailable(f"mqtt: not connected to {self.cfg.host}:{self.cfg.port}")
        try:
            for r in batch:
                dev = self.devices.get(r.logger)
                if dev is None:
                    dev = self.devices[r.logger] = Device(r.logger)
                if dev.learn(r):
                    self._unannounced.add(r.logger)
            for logger in sorted(self._unannounced):
                await self._announce(client, self.devices[logger])
        except aiomqtt.MqttError as e:
            raise SinkUnavailable(f"mqtt: {e}") from e
        todo = [r for r in batch if r.key not in self._sent]
        errors: list[BaseException] = []
        for start in range(0, len(todo), _WINDOW):  # message ids are 16 bits: a window
            chunk = todo[start : start + _WINDOW]
            results = await asyncio.gather(
                *(self._publish_state(client, r) for r in chunk), return_exceptions=True
            )
            for r, res in zip(chunk, results, strict=True):
                if res is None:
                    self._sent[r.key] = None
                elif isinstance(res, aiomqtt.MqttError):
                    errors.append(res)
                else:  # pragma: no cover - a bug, not a broker problem
                    raise res
            if errors:
                break
        while len(self._sent) > _SENT_MAX:
            self._sent.popitem(last=False)
        if errors:
            raise SinkUnavailable(
                f"mqtt: {len(errors)} of {len(todo)} states not published: {errors[0]}"
            )

    async def _publish_state(self, client: aiomqtt.Client, r: Reading) -> None:
        topic = self.topics.state(r.logger, r.channel)
        await client.publish(
            topic, state_payload(r), qos=1, retain=True, timeout=self.publish_timeout
        )

    async def _announce(self, client: aiomqtt.Client, dev: Device) -> None:
        payload = json.dumps(discovery_payload(dev, self.topics), ensure_ascii=False)
        await client.publish(
            self.topics.config(dev.logger),
            payload.encode(),
            qos=1,
            retain=True,
            timeout=self.publish_timeout,
        )
        self.discoveries_sent += 1
        self._unannounced.discard(dev.logger)

    async def _announce_all(self, client: aiomqtt.Client) -> None:
        for dev in list(self.devices.values()):
            await self._announce(client, dev)

    def _client_for(self) -> aiomqtt.Client:
        cfg = self.cfg
        client = aiomqtt.Client(
            cfg.host,
            cfg.port,
            identifier=cfg.topics.client_id,
            username=cfg.username,
            password=cfg.password,
            will=aiomqtt.Will(self.topics.availability, b"offline", qos=1, retain=True),
            keepalive=30,
            max_inflight_messages=_WINDOW,
            timeout=self.publish_timeout,
            tls_context=ssl.create_default_context() if cfg.tls else None,
        )
        client.pending_calls_threshold = 2 * _WINDOW  # our window, not a leak
        return client

    async def _run(self) -> None:
        backoff = 0.2
        while not self._closing:
            try:
                async with self._client_for() as client:
                    await client.publish(self.topics.availability, b"online", qos=1, retain=True)
                    await client.subscribe(self.topics.ha_status, qos=1)
                    await self._announce_all(client)
                    self._client = client
                    self.connects += 1
                    self._connected.set()
                    log.info("mqtt: connected to %s:%d", self.cfg.host, self.cfg.port)
                    backoff = 0.2
                    async for msg in client.messages:
                        if msg.topic.matches(self.topics.ha_status) and msg.payload == b"online":
                            # HA's advice: a small random delay spreads the discovery load.
                            await asyncio.sleep(random.uniform(0.0, 0.2))
                            await self._announce_all(client)
            except (aiomqtt.MqttError, OSError) as e:
                log.warning("mqtt: %s:%d: %s", self.cfg.host, self.cfg.port, e)
            finally:
                self._client = None
                self._connected.clear()
            if self._closing:
                break
            await asyncio.sleep(backoff)
            backoff = min(backoff * 2, 30.0)


def create(table: Mapping[str, object]) -> MqttSink:
    """An MQTT sink straight from a plain ``[mqtt]`` mapping (tests, benchmarks)."""
    return MqttSink(parse_config(of(table, where="mqtt")))


register_sink("mqtt", MqttSink, parse_config)
