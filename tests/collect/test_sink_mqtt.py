"""The MQTT sink and its Home Assistant discovery, checked against the documentation's rules
and against a real mosquitto broker (issue 13, "The collector")."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import subprocess
import sys
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

import aiomqtt
import pytest
import services
from ha_rules import check_device_discovery, gather_messages
from readings_gen import rows, text_row

from sondalog.collect import sink_mqtt
from sondalog.collect.buffer import DiskBuffer, deliver, drain
from sondalog.collect.ha_discovery import (
    Device,
    Topics,
    device_class,
    discovery_payload,
    safe_id,
    state_payload,
)
from sondalog.collect.model import Reading, SinkUnavailable
from sondalog.collect.store_sqlite import row_of

HERE = Path(__file__).parent


def devices(*loggers: str) -> list[Device]:
    out = []
    for lg in loggers:
        dev = Device(lg)
        for r in [*rows(lg, 0, 1, channels=5), text_row(lg, 0, "hello")]:
            dev.learn(r)
        dev.learn(Reading(lg, 6, rows(lg, 0, 1)[0].time, 0, 1, 400.0, name="CO2", unit="ppm"))
        out.append(dev)
    return out


def test_discovery_payloads_follow_the_documented_rules() -> None:
    topics = Topics(prefix="sondalog", discovery="homeassistant", client_id="c 1")
    all_ids: list[str] = []
    for dev in devices("1001", "1002", "bus:A", "bus_A"):
        payload = discovery_payload(dev, topics)
        all_ids += check_device_discovery(topics.config(dev.logger), payload, topics)
        cmps = payload["cmps"]
        assert isinstance(cmps, dict)
        assert set(cmps) == {"text", "ch1", "ch2", "ch3", "ch4", "ch5", "ch6"}
        assert cmps["ch1"]["device_class"] == "temperature"
        assert cmps["ch1"]["unit_of_measurement"] == "°C"
        assert cmps["ch2"]["device_class"] == "voltage"
        assert cmps["ch3"]["device_class"] == "humidity"
        assert cmps["ch3"]["unit_of_measurement"] == "%"  # HA's humidity unit, not "%RH"
        assert cmps["ch4"]["device_class"] == "illuminance"
        assert "device_class" not in cmps["ch6"] and cmps["ch6"]["unit_of_measurement"] == "ppm"
        assert "unit_of_measurement" not in cmps["text"]
        assert cmps["ch1"]["name"] == "T1"
    assert len(all_ids) == len(set(all_ids)) == 4 * 7  # unique ids unique across loggers
    assert safe_id("bus:A") != safe_id("bus_A")
    assert topics.availability == f"sondalog/{safe_id('c 1')}/availability"


def test_device_classes_and_state_messages() -> None:
    assert device_class("°C") == ("temperature", "°C")
    assert device_class(" degC ") == ("temperature", "°C")
    assert device_class("RH") == ("humidity", "%")
    assert device_class("mV") == ("voltage", "mV")
    assert device_class("m3/h") == (None, "m3/h")
    assert device_class(None) == (None, None)
    r = rows("1001", 0, 1)[0]
    assert json.loads(state_payload(r)) == {
        "value": r.value,
        "time": "2026-01-01T00:00:00",
        "counter": 0,
        "type": 1,
    }
    prague = replace(r, utc=datetime(2025, 12, 31, 23, tzinfo=UTC))
    assert json.loads(state_payload(prague))["utc"] == "2025-12-31T23:00:00Z"  # as in SQLite
    assert json.loads(state_payload(prague))["utc"] == row_of(prague)[-1]
    nan = Reading("1", 1, r.time, 0, 1, float("nan"))
    assert json.loads(state_payload(nan))["value"] is None
    long = text_row("1", 0, "x" * 400)
    assert json.loads(state_payload(long))["text"] == "x" * 255


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({}, "mqtt.url: required"),
        ({"url": "http://x"}, "mqtt://host"),
        ({"url": "mqtt://x:99999"}, "url"),
        ({"url": "mqtt://x", "prefix": "a/#"}, "without \\+ or #"),
        ({"url": "mqtt://x", "qos": 2}, "mqtt.qos: unknown table or key 'qos'"),
    ],
)
def test_bad_config_is_refused(table: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        sink_mqtt.create(table)


def test_discovery_states_and_availability_on_a_real_broker(
    mosquitto: services.Mosquitto,
) -> None:
    sink = sink_mqtt.create({"url": mosquitto.url, "client_id": "collector-1"})
    topics = sink.topics
    batch = [*rows("1001", 0, 3), text_row("1001", 2, "door open"), *rows("bus:M1", 0, 1, 2)]

    async def run() -> None:
        await sink.open()
        assert sink.connected
        await sink.write(batch)
        # a subscriber that comes later gets the retained discovery, states and availability
        msgs = await gather_messages(mosquitto.port, ["homeassistant/#", "sondalog/#"])
        by_topic = {str(m.topic): m for m in msgs}
        assert all(m.retain for m in msgs)
        assert by_topic[topics.availability].payload == b"online"
        ids: list[str] = []
        for lg, channels in (("1001", 3), ("bus:M1", 2)):
            m = by_topic[topics.config(lg)]
            assert isinstance(m.payload, bytes)
            payload = json.loads(m.payload)
            ids += check_device_discovery(str(m.topic), payload, topics)
            assert len(payload["cmps"]) == channels + (lg == "1001")
            for cmp in payload["cmps"].values():  # each named state topic carries its state
                state = json.loads(by_topic[cmp["state_topic"]].payload)  # type: ignore[arg-type]
                assert "value" in state or state["text"] == "door open"
        assert len(ids) == len(set(ids))
        last = rows("1001", 2, 1)
        got = json.loads(by_topic[topics.state("1001", 1)].payload)  # type: ignore[arg-type]
        assert got["value"] == last[0].value and got["time"] == "2026-01-01T00:02:00"

        # Home Assistant restarts: its birth message asks for the discovery again
        before = sink.discoveries_sent
        ready = asyncio.Event()
        listen = asyncio.create_task(
            gather_messages(mosquitto.port, ["homeassistant/device/#"], 1.0, ready=ready)
        )
        await ready.wait()
        await asyncio.sleep(0.3)  # the retained copies come first
        async with aiomqtt.Client("127.0.0.1", mosquitto.port, identifier="ha") as ha:
            await ha.publish("homeassistant/status", b"online", qos=1)
        again = await listen
        live = [m for m in again if not m.retain]
        assert sorted(str(m.topic) for m in live) == sorted(
            [topics.config("1001"), topics.config("bus:M1")]
        )
        assert sink.discoveries_sent == before + 2
        await sink.close()
        msgs = await gather_messages(mosquitto.port, [topics.availability], 0.3)
        assert [m.payload for m in msgs] == [b"offline"]  # said on a clean close

    asyncio.run(run())


WRITER = """
import asyncio, sys
from readings_gen import rows
from sondalog.collect import sink_mqtt
async def main():
    sink = sink_mqtt.create({"url": sys.argv[1], "client_id": "doomed"})
    await sink.open()
    await sink.write(rows("5", 0, 1))
    print("ready", flush=True)
    await asyncio.sleep(60)
asyncio.run(main())
"""


def test_last_will_says_offline_when_the_collector_dies(mosquitto: services.Mosquitto) -> None:
    env = {**os.environ, "PYTHONPATH": str(HERE)}
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, mosquitto.url], stdout=subprocess.PIPE, text=True, env=env
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
        topic = Topics(client_id="doomed").availability

        async def run() -> list[bytes]:
            ready = asyncio.Event()
            task = asyncio.create_task(gather_messages(mosquitto.port, [topic], 1.0, ready=ready))
            await ready.wait()
            await asyncio.sleep(0.2)
            os.kill(proc.pid, signal.SIGKILL)
            return [m.payload for m in await task]  # type: ignore[misc]

        assert asyncio.run(run()) == [b"online", b"offline"]
    finally:
        proc.kill()
        proc.wait()


def test_broker_down_then_up_delivers_buffered_batches_once(
    mosquitto: services.Mosquitto, tmp_path: Path
) -> None:
    buf = DiskBuffer(tmp_path / "buffer.sqlite")
    sink = sink_mqtt.create({"url": mosquitto.url, "client_id": "c-restart"})
    batches = [rows("42", i, 1, channels=2) for i in range(6)]
    topics = sink.topics

    async def run() -> list[aiomqtt.Message]:
        await sink.open()
        assert await deliver(buf, sink, batches[0])
        mosquitto.stop()
        for _ in range(100):  # the sink notices the broker is gone
            if not sink.connected:
                break
            await asyncio.sleep(0.02)
        for b in batches[1:5]:
            assert not await deliver(buf, sink, b)
        with pytest.raises(SinkUnavailable):
            await sink.write(batches[5])
        assert buf.count("mqtt") == 4
        mosquitto.start()  # (no persistence: the broker forgot everything retained)
        ready = asyncio.Event()
        listen = asyncio.create_task(
            gather_messages(mosquitto.port, ["sondalog/#", "homeassistant/#"], 1.0, ready=ready)
        )
        await ready.wait()
        assert await sink.wait_connected(10)
        assert await drain(buf, sink) == 4
        assert await deliver(buf, sink, batches[5])
        msgs = await listen
        await sink.close()
        return msgs

    msgs = asyncio.run(run())
    assert buf.count("mqtt") == 0
    assert sink.connects == 2
    states = [
        (str(m.topic), json.loads(m.payload)["time"])  # type: ignore[arg-type]
        for m in msgs
        if str(m.topic).startswith(f"{topics.prefix}/42/")
    ]
    expected = [(topics.state("42", r.channel), r.time.isoformat()) for b in batches[1:] for r in b]
    assert sorted(states) == sorted(expected)  # every buffered reading once, none twice
    # the discovery was sent again on reconnect (the restarted broker had lost it)
    assert any(str(m.topic) == topics.config("42") for m in msgs)


def test_discovery_is_due_again_only_when_a_channel_changes() -> None:
    dev = Device("1001")
    first = rows("1001", 0, 1, channels=2)
    assert [dev.learn(r) for r in first] == [True, True]
    assert not any(dev.learn(r) for r in rows("1001", 1, 1, channels=2))  # same channels
    assert dev.learn(rows("1001", 2, 1, channels=3)[2])  # a new channel
    renamed = Reading("1001", 1, first[0].time, 0, 1, 1.0, name="Air", unit="°C")
    assert dev.learn(renamed)
    assert not dev.learn(Reading("1001", 1, first[0].time, 0, 1, 1.0))  # no name: keep it
    assert dev.channels[1] == ("Air", "°C")
