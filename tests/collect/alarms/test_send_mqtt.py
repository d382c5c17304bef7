"""MQTT notifications (issue 21) through a real mosquitto: the Home Assistant discovery of a
rule's binary_sensor, its retained ON/OFF state, the availability with its last will, and
the JSON event of every notification."""

from __future__ import annotations

import asyncio
import json
import signal
import subprocess
import sys
from typing import Any

import aiomqtt

from sondalog.collect.alarms import Message, Notify
from sondalog.collect.alarms.send_mqtt import MqttAlarms, MqttSettings
from sondalog.collect.alarms.senders import DeliveryError, sender_for


def message(what: str, subject: str, key: str, rule: str | None = "hot room") -> Message:
    return Message(
        key=key,
        destination="ha",
        what=what,  # type: ignore[arg-type]
        event=key.split("/")[0],
        text=f"{subject} Air above 40",
        created=0.0,
        next_try=0.0,
        alarm="a1" if rule else None,
        rule=rule,
        subject=subject if rule else None,
        value=41.5 if rule else None,
        time=1709290800.0 if rule else None,
    )


def ha(url: str, discovery: bool = True) -> MqttAlarms:
    settings = MqttSettings(url, "site/alarms", discovery, "hass")
    sender = sender_for(Notify("ha", "mqtt", settings))
    assert isinstance(sender, MqttAlarms)
    return sender


async def retained(port: int, topic: str, count: int) -> dict[str, bytes]:
    """The retained messages under ``topic`` (a fresh subscriber gets them at once)."""
    out: dict[str, bytes] = {}
    async with aiomqtt.Client("127.0.0.1", port, identifier="check-retained") as c:
        await c.subscribe(topic, qos=1)
        async with asyncio.timeout(5):
            async for m in c.messages:
                out[str(m.topic)] = bytes(m.payload)  # type: ignore[arg-type]
                if len(out) == count:
                    break
    return out


def test_discovery_state_availability_and_events(mosquitto: Any) -> None:
    sender = ha(mosquitto.url)

    async def run() -> tuple[list[Any], dict[str, bytes], dict[str, bytes]]:
        events: list[Any] = []
        async with aiomqtt.Client("127.0.0.1", mosquitto.port, identifier="watch") as watch:
            await watch.subscribe("site/alarms/alarm/event", qos=1)
            await sender.send(message("raised", "F01/1", "a1-1/raised/ha"))
            await sender.send(message("raised", "F02/1", "a2-1/raised/ha"))
            await sender.send(message("cleared", "F01/1", "a1-1/cleared/ha"))
            on = await retained(mosquitto.port, "#", 3)
            await sender.send(message("cleared", "F02/1", "a2-1/cleared/ha"))
            await sender.send(message("summary", "", "s-1/summary/ha", rule=None))
            async with asyncio.timeout(5):
                async for m in watch.messages:
                    events.append((m.retain, json.loads(bytes(m.payload))))  # type: ignore[arg-type]
                    if len(events) == 5:
                        break
        await sender.close()
        after = await retained(mosquitto.port, "#", 3)
        return events, on, after

    events, on, after = asyncio.run(run())
    config = json.loads(
        on["hass/binary_sensor/sondalog_alarm_hot_room_" + _hash("hot room") + "/config"]
    )
    node = "sondalog_alarm_hot_room_" + _hash("hot room")
    assert config["unique_id"] == node and config["name"] == "hot room"
    assert config["device_class"] == "problem"
    state_topic = config["state_topic"]
    assert state_topic == f"site/alarms/hot_room_{_hash('hot room')}/state"
    assert (config["payload_on"], config["payload_off"]) == ("ON", "OFF")
    assert config["availability_topic"] == "site/alarms/availability"
    assert (config["payload_available"], config["payload_not_available"]) == ("online", "offline")
    assert on[state_topic] == b"ON"  # F02/1 is still raised after F01/1 cleared
    assert on["site/alarms/availability"] == b"online"
    assert after[state_topic] == b"OFF"
    assert after["site/alarms/availability"] == b"offline"  # a clean close says so
    assert [e[1]["key"] for e in events] == [
        "a1-1/raised/ha",
        "a2-1/raised/ha",
        "a1-1/cleared/ha",
        "a2-1/cleared/ha",
        "s-1/summary/ha",
    ]
    assert not any(retain for retain, _ in events)
    first = events[0][1]
    assert (first["rule"], first["subject"], first["what"], first["value"]) == (
        "hot room",
        "F01/1",
        "raised",
        41.5,
    )
    assert first["time"] == "2024-03-01T11:00:00Z"


KILLED = """
import asyncio, sys
from sondalog.collect.alarms import Message, Notify
from sondalog.collect.alarms.send_mqtt import MqttSettings
from sondalog.collect.alarms.senders import sender_for

async def main():
    notify = Notify("ha", "mqtt", MqttSettings(sys.argv[1], "site/alarms", False, "hass"))
    sender = sender_for(notify)
    await sender.send(Message(key="a1-1/raised/ha", destination="ha", what="raised",
                              event="a1-1", text="hot", created=0.0, next_try=0.0,
                              alarm="a1", rule="hot", subject="F01/1"))
    print("sent", flush=True)
    await asyncio.sleep(60)

asyncio.run(main())
"""


def test_the_last_will_says_offline_when_the_collector_dies(mosquitto: Any) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-c", KILLED, mosquitto.url], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline() == "sent\n"
        before = asyncio.run(retained(mosquitto.port, "#", 2))
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        after = asyncio.run(retained(mosquitto.port, "#", 2))
    finally:
        proc.kill()
        proc.wait()
    assert before == {"site/alarms/availability": b"online", "site/alarms/hot/state": b"ON"}
    assert after == {"site/alarms/availability": b"offline", "site/alarms/hot/state": b"ON"}


def test_a_broker_away_is_a_delivery_error_then_it_reconnects(mosquitto: Any) -> None:
    sender = ha(mosquitto.url, discovery=False)

    async def run() -> str:
        await sender.send(message("raised", "F01/1", "a1-1/raised/ha"))
        mosquitto.stop()
        try:
            await sender.send(message("cleared", "F01/1", "a1-1/cleared/ha"))
        except DeliveryError as exc:
            error = str(exc)
        else:
            raise AssertionError("no DeliveryError with the broker down")
        mosquitto.start()
        await sender.send(message("cleared", "F01/1", "a1-1/cleared/ha"))  # the retry
        await sender.close()
        return error

    assert "127.0.0.1" in asyncio.run(run())
    seen = asyncio.run(retained(mosquitto.port, "#", 2))
    state = f"site/alarms/hot_room_{_hash('hot room')}/state"
    assert seen == {"site/alarms/availability": b"offline", state: b"OFF"}


def _hash(text: str) -> str:
    import hashlib

    return hashlib.sha1(text.encode()).hexdigest()[:6]
