"""Home Assistant MQTT discovery for the collector's loggers (pure: topics and payloads).

Follows Home Assistant's "MQTT Discovery" documentation, section "Device discovery
payload": one retained message per logger on ``<discovery_prefix>/device/<object_id>/config``
whose root carries the shared ``dev`` (device) and ``o`` (origin, required for device
discovery) mappings and the availability options, and whose ``cmps`` mapping holds one
component per channel. Every component has its platform ``p``, a ``unique_id`` and its own
``state_topic``; ``<object_id>`` and the component ids use only ``[a-zA-Z0-9_-]``.

State messages are JSON, one per reading, retained, on the component's state topic::

    {"value": 21.5, "time": "2026-11-30T01:00:00", "counter": 0, "type": 1}

``value`` is ``null`` for "no valid value" (Home Assistant then shows the sensor as
unknown); ``time`` is the logger's own clock (``utc``, ``2026-11-30T00:00:00Z`` as in the
store, is added when known). A text row
(types 3..9, §6.8.1) goes to the logger's ``text`` component as ``{"text": ...}``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from dataclasses import dataclass, field
from importlib import metadata

from sondalog.collect.model import Reading, utc_text

_SAFE = re.compile(r"[^A-Za-z0-9_-]")

#: Unit (as a logger may spell it, lower case) -> (Home Assistant device class, HA unit).
UNIT_CLASSES: dict[str, tuple[str, str]] = {
    "°c": ("temperature", "°C"),
    "c": ("temperature", "°C"),
    "degc": ("temperature", "°C"),
    "st.c": ("temperature", "°C"),
    "°f": ("temperature", "°F"),
    "k": ("temperature", "K"),
    "v": ("voltage", "V"),
    "mv": ("voltage", "mV"),
    "a": ("current", "A"),
    "ma": ("current", "mA"),
    "%": ("humidity", "%"),
    "%rh": ("humidity", "%"),
    "rh": ("humidity", "%"),
    "pa": ("pressure", "Pa"),
    "hpa": ("pressure", "hPa"),
    "kpa": ("pressure", "kPa"),
    "mbar": ("pressure", "mbar"),
    "bar": ("pressure", "bar"),
    "w": ("power", "W"),
    "kw": ("power", "kW"),
    "hz": ("frequency", "Hz"),
    "lx": ("illuminance", "lx"),
}

#: Home Assistant keeps at most 255 characters of a sensor's state.
STATE_MAX = 255


def device_class(unit: str | None) -> tuple[str | None, str | None]:
    """The device class and the unit Home Assistant expects for a logger's ``unit``.

    An unknown unit keeps its spelling and gets no device class (HA accepts any unit then).
    """
    if not unit:
        return None, None
    known = UNIT_CLASSES.get(unit.strip().lower())
    if known is None:
        return None, unit.strip()
    return known


def safe_id(text: str) -> str:
    """``text`` reduced to ``[a-zA-Z0-9_-]``; a short hash keeps reduced ids distinct."""
    clean = _SAFE.sub("_", text)
    if clean != text or not clean:
        clean += "_" + hashlib.sha1(text.encode()).hexdigest()[:6]
    return clean


def origin() -> dict[str, str]:
    """The ``o`` mapping: which application sent the discovery."""
    return {"name": "sondalog", "sw": _version()}


@functools.cache
def _version() -> str:
    try:
        return metadata.version("sondalog")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a bare tree
        return "0"


@dataclass(frozen=True, slots=True)
class Topics:
    """Where the collector publishes: ``prefix`` for states, ``discovery`` for HA."""

    prefix: str = "sondalog"
    discovery: str = "homeassistant"
    client_id: str = "sondalog-collector"

    @property
    def availability(self) -> str:
        """The collector's availability (``online``, last will ``offline``), retained."""
        return f"{self.prefix}/{safe_id(self.client_id)}/availability"

    @property
    def ha_status(self) -> str:
        """Home Assistant's birth/last-will topic: ``online`` asks for discovery again."""
        return f"{self.discovery}/status"

    def node(self, logger: str) -> str:
        return "sondalog_" + safe_id(logger)

    def config(self, logger: str) -> str:
        return f"{self.discovery}/device/{self.node(logger)}/config"

    def state(self, logger: str, channel: int) -> str:
        """Channel ``n`` > 0 publishes on ``.../ch<n>``, text rows (channel 0) on ``.../text``."""
        leaf = "text" if channel == 0 else f"ch{channel}"
        return f"{self.prefix}/{safe_id(logger)}/{leaf}"


@dataclass
class Device:
    """What the collector knows of one logger's channels (grows as readings arrive)."""

    logger: str
    channels: dict[int, tuple[str | None, str | None]] = field(default_factory=dict)

    def learn(self, r: Reading) -> bool:
        """Note ``r``'s channel (name, unit); True when the discovery must be sent again."""
        known = self.channels.get(r.channel)
        now = (r.name, r.unit) if r.channel else (None, None)
        if known is None or (r.channel and now != known and (r.name or r.unit)):
            self.channels[r.channel] = now
            return True
        return False


def _model(logger: str) -> str:
    return "HCTMPS1" if logger.startswith("bus:") else "ALA1"


def discovery_payload(dev: Device, topics: Topics) -> dict[str, object]:
    """The device discovery payload of one logger (see the module docstring)."""
    node = topics.node(dev.logger)
    cmps: dict[str, dict[str, object]] = {}
    for channel in sorted(dev.channels):
        name, unit = dev.channels[channel]
        cmp: dict[str, object] = {
            "p": "sensor",
            "state_topic": topics.state(dev.logger, channel),
            "json_attributes_topic": topics.state(dev.logger, channel),
        }
        if channel == 0:
            cmp.update(name="Message", unique_id=f"{node}_text")
            cmp["value_template"] = "{{ value_json.text }}"
            cmps["text"] = cmp
            continue
        cls, ha_unit = device_class(unit)
        cmp.update(name=name or f"Channel {channel}", unique_id=f"{node}_ch{channel}")
        cmp["value_template"] = "{{ value_json.value }}"
        cmp["state_class"] = "measurement"
        if ha_unit:
            cmp["unit_of_measurement"] = ha_unit
        if cls:
            cmp["device_class"] = cls
        cmps[f"ch{channel}"] = cmp
    model = _model(dev.logger)
    serial = dev.logger.removeprefix("bus:")
    return {
        "dev": {
            "ids": [node],
            "name": f"{model} {serial}",
            "mf": "sondalog",
            "mdl": model,
            "sn": serial,
        },
        "o": origin(),
        "availability_topic": topics.availability,
        "payload_available": "online",
        "payload_not_available": "offline",
        "qos": 1,
        "cmps": cmps,
    }


def state_payload(r: Reading) -> bytes:
    """The JSON state message of one reading (see the module docstring)."""
    body: dict[str, object]
    if r.channel == 0:
        body = {"text": (r.text or "")[:STATE_MAX]}
    else:
        finite = r.value is not None and math.isfinite(r.value)
        body = {"value": r.value if finite else None}
    body.update(time=r.time.isoformat(timespec="seconds"), counter=r.counter, type=r.type)
    if r.utc is not None:
        body["utc"] = utc_text(r.utc)
    return json.dumps(body, ensure_ascii=False, separators=(",", ":")).encode()
