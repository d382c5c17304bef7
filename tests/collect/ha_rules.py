"""Checks shared by the MQTT tests: Home Assistant's device discovery rules, a subscriber."""

from __future__ import annotations

import asyncio
import os
import re

import aiomqtt

from sondalog.collect.ha_discovery import Topics

SAFE = re.compile(r"^[A-Za-z0-9_-]+$")


def check_device_discovery(topic: str, payload: dict[str, object], topics: Topics) -> list[str]:
    """The rules of HA's "Device discovery payload"; returns the components' unique ids."""
    m = re.fullmatch(rf"{topics.discovery}/device/([^/]+)/config", topic)
    assert m and SAFE.match(m.group(1)), topic
    dev = payload["dev"]
    assert isinstance(dev, dict) and dev["ids"] and dev["name"]
    origin = payload["o"]
    assert isinstance(origin, dict) and origin["name"] == "sondalog"
    assert payload["availability_topic"] == topics.availability
    cmps = payload["cmps"]
    assert isinstance(cmps, dict) and cmps
    ids = []
    for cid, cmp in cmps.items():
        assert SAFE.match(cid), cid
        assert cmp["p"] == "sensor"
        assert len(set(cmp) - {"p"}) >= 1  # at least one component option
        assert cmp["unique_id"]
        state = cmp["state_topic"]
        assert state.startswith(topics.prefix + "/") and not set(state) & {"+", "#"}
        assert cmp["value_template"].startswith("{{ value_json.")
        ids.append(cmp["unique_id"])
    return ids


async def gather_messages(
    port: int, subscribe: list[str], quiet: float = 0.4, *, ready: asyncio.Event | None = None
) -> list[aiomqtt.Message]:
    """Every message on ``subscribe`` until ``quiet`` seconds pass without one (max 10 s)."""
    got: list[aiomqtt.Message] = []
    async with aiomqtt.Client("127.0.0.1", port, identifier=f"sub{os.getpid()}") as c:
        for t in subscribe:
            await c.subscribe(t, qos=1)
        if ready is not None:
            ready.set()
        async with asyncio.timeout(10):
            while True:
                try:
                    async with asyncio.timeout(quiet):
                        got.append(await anext(aiter(c.messages)))
                except TimeoutError:
                    return got
