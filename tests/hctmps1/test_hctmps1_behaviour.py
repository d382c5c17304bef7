"""State and timing of the module core: <connect>, lockout, EEPROM, queue, autonomous mode."""

from __future__ import annotations

import random

import pytest
from hctmps1_helpers import T0, Bench, frame

from sondalog.hctmps1 import (
    CONNECT_TIMEOUT,
    QUEUE_MAX,
    TEMP,
    EepromImage,
    Hctmps1Module,
    MemoryEeprom,
    ModuleConfig,
    slot_time,
)


def test_connect_belongs_to_the_requester() -> None:
    bench = Bench()
    bench.connect(src="PC")
    assert bench.ask("LISTSUP", src="OTHER") == b""
    assert bench.ask("LISTSUP", src="PC") == frame("PC", "T1", "RLISTSUP.<EMPTY>")
    bench.connect(src="OTHER")
    assert bench.ask("DISCONNECT", src="PC") == frame("PC", "T1", "RDISCONNECT.<OK>")
    assert bench.ask("LISTSUP", src="PC") == b""
    assert bench.ask("LISTSUP", src="OTHER") == frame("OTHER", "T1", "RLISTSUP.<EMPTY>")


def test_connect_times_out_after_300_s_without_a_command() -> None:
    bench = Bench()
    bench.connect()
    # Any command from the owner, even one that needs no context, keeps it alive.
    assert bench.ask("HELLO", dt=CONNECT_TIMEOUT - 1) != b""
    assert bench.ask("LISTP", dt=CONNECT_TIMEOUT - 1) == frame("PC", "T1", "RLISTP.<EMPTY>")
    assert bench.ask("LISTP", dt=CONNECT_TIMEOUT + 0.5) == b""


def test_wrong_password_lockout() -> None:
    bench = Bench()
    for _ in range(5):
        assert bench.ask("CONNECT.nope", dt=1) == b""
    # Locked out for 60 s: even the right password is ignored.
    assert bench.ask("CONNECT.0000", dt=1) == b""
    assert bench.ask("CONNECT.0000", dt=57) == b""
    assert bench.ask("CONNECT.0000", dt=2) == frame("PC", "T1", "RCONNECT.<OK>")


def test_wrong_passwords_spread_over_more_than_60_s_do_not_lock() -> None:
    bench = Bench()
    for _ in range(10):
        assert bench.ask("CONNECT.nope", dt=20) == b""
    assert bench.ask("CONNECT.0000", dt=1) == frame("PC", "T1", "RCONNECT.<OK>")


def test_settings_are_ram_until_saveee_and_reinit_reverts() -> None:
    eeprom = MemoryEeprom()
    bench = Bench(eeprom=eeprom)
    bench.connect()
    bench.ask("ADDSUP.L1")
    bench.ask("NEWPW.pw1")
    assert bench.ask("SAVEEE") == frame("PC", "T1", "RSAVEEE.<OK>")
    assert eeprom.image == EepromImage("T1", "pw1", ("L1",), None)
    bench.ask("ADDSUP.L2")
    bench.ask("ADDP.X")
    assert bench.ask("REINIT") == frame("PC", "T1", "RREINIT.<OK>")
    assert bench.ask("LISTSUP") == frame("PC", "T1", "RLISTSUP.L1")
    assert bench.ask("LISTP") == frame("PC", "T1", "RLISTP.<EMPTY>")


def test_resee_restores_factory_settings_without_saving() -> None:
    eeprom = MemoryEeprom(EepromImage("T7", "pw", ("L1",), "SYM"))
    bench = Bench(eeprom=eeprom)
    assert bench.module.module_id == "T7"  # the EEPROM's ID wins over the configured one
    bench.connect(password="pw")
    assert bench.ask("RESEE") == frame("PC", "T7", "RRESEE.<OK>")
    assert bench.module.settings == EepromImage("T1", "0000", (), None)
    assert eeprom.image == EepromImage("T7", "pw", ("L1",), "SYM")
    assert bench.ask("LISTSUP", dst="T1") == frame("PC", "T1", "RLISTSUP.<EMPTY>")


def test_power_up_loses_ram_state_but_keeps_the_eeprom() -> None:
    eeprom = MemoryEeprom()
    bench = Bench(eeprom=eeprom)
    bench.connect()
    bench.ask("SETMID.T2")
    bench.ask("SAVEEE", dst="T2")
    bench.ask("ADDP.LOST", dst="T2")
    bench.ask("CSSERVON.PC", dst="T2")
    bench.ask("AUTOON", dst="T2")
    again = Bench(eeprom=eeprom)
    assert again.module.module_id == "T2"
    assert again.ask("LISTP", dst="T2") == b""  # no <connect> after power-up
    again.connect()
    assert again.ask("LISTP") == frame("PC", "T2", "RLISTP.<EMPTY>")
    assert again.ask("CSSERVLIST") == frame("PC", "T2", "RCSSERVLIST.<EMPTY>")
    assert again.ask("GETMODE") == frame("PC", "T2", "RGETMODE.MDISOF")


def test_pv_queues_a_frame_for_every_distribution_entry() -> None:
    bench = Bench()
    bench.connect()
    bench.ask("ADDSUP.L1")
    bench.ask("CSSERVON.L2")
    bench.ask("CSSERVON.L1")  # in both lists: one frame
    assert bench.ask("PV") == frame("PC", "T1", "RPV.21.44")
    assert bench.ask("REPLY") == frame("L1", "T1", "RPV.21.44")
    assert bench.ask("REPLY") == frame("L2", "T1", "RPV.21.44")
    assert bench.ask("REPLY") == frame("PC", "T1", "RREPLY.NODATA")


def test_measurement_cycle_and_conversion_time() -> None:
    bench = Bench(value=20.0)
    assert bench.ask("PV") == frame("PC", "T1", "RPV.20.00")
    bench.value = 22.03  # quantised to 22.0 (0.0625 steps)
    assert bench.module.next_deadline() == T0 + 10.75
    assert bench.ask("PV", dt=10.7) == frame("PC", "T1", "RPV.20.00")
    assert bench.ask("PV", dt=0.05) == frame("PC", "T1", "RPV.22.00")
    bench.value = -0.01
    assert bench.ask("PV", dt=10) == frame("PC", "T1", "RPV.0.00")
    bench.value = 200
    assert bench.ask("PV", dt=10) == frame("PC", "T1", "RPV.125.00")


def test_humidity_resolution_and_range() -> None:
    from sondalog.hctmps1 import HUM

    bench = Bench(HUM, "H1", 48.46)
    assert bench.ask("PV") == frame("PC", "H1", "RPV.48.5")
    bench.value = 120
    assert bench.ask("PV", dt=10.08) == frame("PC", "H1", "RPV.100.0")


def test_autonomous_mode_queues_each_cycle_and_keeps_the_newest_32() -> None:
    bench = Bench(value=0.0)
    bench.signal = lambda t: (t - T0) / 10  # a ramp: one step per cycle
    bench.ask("CSSERVON.PC")
    bench.ask("AUTOON")
    assert bench.ask("REPLY") == frame("PC", "T1", "RREPLY.NODATA")
    bench.send(b"", dt=40 * 10.0 + 1)
    assert len(bench.module.queue) == QUEUE_MAX
    assert bench.module.dropped == 40 - QUEUE_MAX
    first = bench.ask("REPLY")
    # Cycle k completes at T0 + 10 k + 0.75: the oldest kept is cycle 9.
    assert first == frame("PC", "T1", "RPV.9.06")
    for _ in range(QUEUE_MAX - 1):
        assert b"RPV." in bench.ask("REPLY")
    assert bench.ask("REPLY") == frame("PC", "T1", "RREPLY.NODATA")


def test_broadcast_replies_are_delayed_by_whole_slots() -> None:
    slot = slot_time(9600)
    seen = set()
    for seed in range(40):
        bench = Bench(seed=seed)
        immediate = bench.ask("HELLO", dst="*")
        if immediate:
            seen.add(0)
            continue
        deadline = bench.module.next_deadline()
        assert deadline is not None
        slots = round((deadline - T0) / slot)
        assert 1 <= slots <= 15
        assert deadline == pytest.approx(T0 + slots * slot)
        assert bench.send(b"", dt=deadline - T0 - 1e-6) == b""
        reply = bench.send(b"", dt=2e-6)
        assert reply == frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
        seen.add(slots)
    assert len(seen) > 8


def test_bad_crc_foreign_dst_and_garbage_get_no_reply() -> None:
    bench = Bench()
    good = frame("T1", "PC", "HELLO")
    bad_crc = good.replace(b"|9BBE", b"|9BBF")
    assert bench.send(bad_crc) == b""
    assert bench.send(frame("T2", "PC", "HELLO")) == b""
    assert bench.send(b"\x00\xffgarbage" + bad_crc) == b""
    assert bench.send(b"xx:T1,PC,HEL") == b""
    assert bench.send(b"LO|9BBE\r") == b""
    assert bench.send(b"\n") == frame("PC", "T1", "RHELLO.HCTMPS1-temp server (DS18B20)")
    # Noise before ':' is skipped, and a good frame after a broken one is still found.
    assert bench.send(b"\x13\x88" + good) != b""
    assert bench.send(b":T1,PC,HE\x81" + good) != b""


def test_frames_for_other_modules_and_replies_are_ignored() -> None:
    bench = Bench()
    assert bench.send(frame("T1", "H1", "RPV.48.5")) == b""
    assert bench.send(frame("T1", "H1", "RREPLY.NODATA")) == b""


def test_sensor_failure_keeps_the_last_value() -> None:
    def broken(t: float) -> float:
        if t > T0 + 5:
            raise OSError("sensor gone")
        return 20.0

    module = Hctmps1Module(ModuleConfig("T1", TEMP), broken, MemoryEeprom(), random.Random(0), T0)
    out = module.handle(frame("T1", "PC", "PV"), T0 + 30)
    assert out.data == frame("PC", "T1", "RPV.20.00")


def test_config_is_validated() -> None:
    with pytest.raises(ValueError):
        ModuleConfig("bad id", TEMP)
    with pytest.raises(ValueError):
        ModuleConfig("T1", TEMP, cycle=0.5)
