"""Modules with the same committed values share what those values determine (issue 24;
sondalog.ala1.shared), and nothing a module answers changes for it."""

from __future__ import annotations

import random

import pytest
from ala1_module import Module

from sondalog.ala1 import Engine, Identity, Version
from sondalog.ala1.measure import channel_config
from sondalog.ala1.state import Transaction
from sondalog.backends.store.ala1_nv import SqliteNvStore

#: Write lines whose values other values depend on (device type -> calibration), that
#: change channel configurations, messages, outputs and the identity's own defaults.
WRITES = (
    "write device 1 type DS18B20",
    "write device 1 type MSP430TA",
    "write device 2 type DS18B20",
    "write channel 1 device 1",
    "write channel 2 device 2",
    "write channel 1 sampling period 000100",
    "write channel 2 sampling period 000010",
    "write channel 3 type 11",
    "write channel max number 4",
    "write channel 1 cal mult value 2.5",
    "write message 1 period 000100",
    "write message 2 of channel function up",
    "write output 2 device 1",
    "write i description station",
    "write global reset",
)


def serial_module(serial: str) -> Module:
    module = Module()
    module.engine = Engine(Identity(Version.V2_10, serial), SqliteNvStore(":memory:"), module.now)
    module.line = module.engine.open_line()
    return module


def test_alike_modules_share_and_keep_their_own_identity() -> None:
    a, b = serial_module("A0001"), serial_module("B0002")
    sa, sb = a.engine.state, b.engine.state
    assert sa.derived() is sb.derived()
    assert sa.channel_config(1) is sb.channel_config(1)
    # the identity's own factory values are never shared (§6.3.6-7: the serial number)
    assert a.read("read i description") == "A0001"
    assert b.read("read i description") == "B0002"
    assert a.read("read i type") == "A0001"
    # a change is the module's own: its calibration by type (§6.4.4.3), its channel
    a.ok("write device 1 type DS18B20")
    a.ok("write channel 1 sampling period 000100")
    assert sa.derived() is not sb.derived()
    assert a.read("read device 1 cal mult") != b.read("read device 1 cal mult")
    assert sa.channel_config(1).period == 60
    assert sb.channel_config(1).period == 0
    # and a module written alike shares again
    b.ok("write device 1 type DS18B20")
    b.ok("write channel 1 sampling period 000100")
    assert sa.derived() is sb.derived()
    assert b.read("read i description") == "B0002"


def test_messages_of_alike_modules_share_their_configurations() -> None:
    a, b = serial_module("A0001"), serial_module("B0002")
    a.ok("write message 1 period 000100")
    b.ok("write message 1 period 000100")
    ma, mb = a.engine.messages._messages[1], b.engine.messages._messages[1]
    assert ma.config is mb.config
    assert ma.due is not None and ma.due == mb.due
    b.ok("write message 1 period 000000")
    assert a.engine.messages._messages[1].due is not None
    assert b.engine.messages._messages[1].due is None


@pytest.mark.parametrize("seed", range(12))
def test_shared_values_are_what_the_module_computes_alone(seed: int) -> None:
    """Random writes on three modules (two alike, one its own way): every value and channel
    configuration read through the shared cache is what an uncached view computes."""
    rng = random.Random(seed)
    modules = [serial_module(f"S{seed}-{n}") for n in range(3)]
    for _ in range(8):
        common = rng.choice(WRITES)
        for index, module in enumerate(modules):
            line = rng.choice(WRITES) if index == 2 else common
            assert module.ask(line).endswith(b"OK\r\n"), line
        for module in modules:
            state = module.engine.state
            plain = Transaction(state, 0.0)
            for key in state.keys:
                assert state.get(key) == plain.get(key), key
            maximum = int(state.get("channel max number"))
            for ch in range(1, maximum + 1):
                assert state.channel_config(ch) == channel_config(Transaction(state, 0.0), ch)
    assert modules[0].engine.state.derived() is modules[1].engine.state.derived()


def test_stored_values_are_checked_once_for_alike_modules_and_repaired_in_each() -> None:
    """Values found usable are so for every module of the same values (issue 24: checked
    once at a fleet's start); an unusable one is repaired in every module holding it."""
    from sondalog.backends.store.ala1_nv import NvDatabase

    database = NvDatabase(":memory:")
    good = {"channel max number": "3", "channel 1 cal mult value": "2.5"}
    bad = {**good, "channel 2 record change": "x"}
    for serial, values in (("G1", good), ("G2", good), ("B1", bad), ("B2", bad)):
        database.write([(serial, (values, 0.0, None, None))])
    states = [
        Engine(Identity(Version.V2_10, serial), database.store(serial), 0.0).state
        for serial in ("G1", "G2", "B1", "B2")
    ]
    assert states[0].derived() is states[1].derived()
    assert states[0].derived().memo.get("usable") is True
    for state in states[2:]:  # each repaired, its own commit: the store lost the value too
        assert state.values == good
        assert database.store(state.identity.serial_number).load()[0] == good
    database.close()
