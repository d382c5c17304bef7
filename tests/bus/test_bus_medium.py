"""The RS-485 line model: byte timing, collisions, noise (pure, explicit times)."""

from __future__ import annotations

import random

import pytest
from bus_helpers import START, make_module

from sondalog.hctmps1 import FrameDecoder, encode_frame
from sondalog.world.bus import DEFAULT_TURNAROUND, BusCore
from sondalog.world.medium import Medium, byte_time


def test_a_byte_takes_ten_bit_times() -> None:
    assert byte_time(9600) == pytest.approx(10 / 9600)


def test_bytes_arrive_when_their_stop_bit_has_passed() -> None:
    medium = Medium(9600)
    data = encode_frame("T1", "PC", "HELLO")
    medium.transmit(1, data, 10.0)
    end = 10.0 + len(data) * 10 / 9600
    assert medium.next_deadline() == pytest.approx(end)
    assert medium.receive(end - 1e-6) == []
    assert medium.receive(end) == [(1, data)]
    assert medium.next_deadline() is None


def test_one_nodes_transmissions_follow_each_other() -> None:
    medium = Medium(9600)
    first = medium.transmit(1, b"abc\n", 0.0)
    second = medium.transmit(1, b"def\n", 0.0)
    assert second.start == pytest.approx(first.end)
    assert medium.collisions == 0
    assert medium.receive(1.0) == [(1, b"abc\n"), (1, b"def\n")]


def test_overlapping_transmissions_corrupt_each_other() -> None:
    medium = Medium(9600)
    a = encode_frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
    b = encode_frame("PC", "H1", "RHELLO.HCTMPS1-hum server (SHT11)")
    medium.transmit(1, a, 0.0)
    medium.transmit(2, b, 0.02)  # starts while a is still on the line
    assert medium.collisions == 1
    decoder = FrameDecoder()
    for _, chunk in medium.receive(1.0):
        assert decoder.feed(chunk) == []
    assert decoder.rejected > 0


def test_back_to_back_transmissions_do_not_collide() -> None:
    medium = Medium(9600)
    a = encode_frame("PC", "T1", "RPV.21.44")
    first = medium.transmit(1, a, 0.0)
    medium.transmit(2, a, first.end)
    decoder = FrameDecoder()
    frames = [f for _, chunk in medium.receive(1.0) for f in decoder.feed(chunk)]
    assert len(frames) == 2
    assert medium.collisions == 0


def test_noise_flips_bits_and_the_crc_catches_it() -> None:
    medium = Medium(9600, bit_error_rate=0.01, rng=random.Random(3))
    data = encode_frame("PC", "T1", "RPV.21.44")
    for i in range(200):
        medium.transmit(1, data, i * 0.1)
    decoder = FrameDecoder()
    good = [f for _, chunk in medium.receive(100.0) for f in decoder.feed(chunk)]
    assert medium.bit_errors > 0
    assert 0 < len(good) < 200
    assert all(f.encode() == data for f in good)


def test_bad_parameters_are_refused() -> None:
    with pytest.raises(ValueError):
        Medium(0)
    with pytest.raises(ValueError):
        Medium(9600, bit_error_rate=1.0)


def test_reply_timing_on_the_bus_core() -> None:
    core = BusCore(9600)
    core.add_module(make_module("T1", seed=1))
    host = core.add_port()
    request = encode_frame("T1", "PC", "HELLO")
    core.write(host, request, START)
    reply = encode_frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
    bt = 10 / 9600
    arrival = START + len(request) * bt + DEFAULT_TURNAROUND + len(reply) * bt
    assert core.run_until(arrival - 1e-6) == {}
    assert core.run_until(arrival + 1e-9) == {host: reply}


def test_a_host_does_not_hear_itself_but_hears_other_hosts() -> None:
    core = BusCore(9600)
    one, two = core.add_port(), core.add_port()
    data = encode_frame("XX", "PC", "HELLO")
    core.write(one, data, START)
    assert core.run_until(START + 1) == {two: data}


def test_modules_ignore_each_others_replies() -> None:
    core = BusCore(9600)
    core.add_module(make_module("T1", seed=1))
    core.add_module(make_module("T2", seed=2))
    host = core.add_port()
    core.write(host, encode_frame("T1", "PC", "PV"), START)
    got = core.run_until(START + 1)
    assert got == {host: encode_frame("PC", "T1", "RPV.21.50")}
    assert core.medium.collisions == 0
