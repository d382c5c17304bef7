"""Put the modules of a site on a bus (hctmps1.md §1, docs/hctmps1.md "Site file")."""

from __future__ import annotations

import random
from pathlib import Path

from sondalog.backends.sensor_bank import SensorBank
from sondalog.backends.sim.site_bus import BusSite
from sondalog.backends.store.eeprom import EepromDatabase
from sondalog.hctmps1.eeprom import EepromStore, MemoryEeprom
from sondalog.hctmps1.module import Hctmps1Module, ModuleConfig
from sondalog.hctmps1.variants import SensorSource, variant_for
from sondalog.protocol.hctmps1_frames import slot_time
from sondalog.world.bus import BusCore

DEFAULT_BAUD = 9600


def build_bus(
    site: BusSite,
    now: float,
    baud: int | None = None,
    state_dir: Path | None = None,
    bit_error_rate: float | None = None,
    seed: int | None = None,
    sensors: SensorBank | None = None,
) -> tuple[BusCore, EepromDatabase | None]:
    """A bus holding the site's modules, their EEPROM in ``state_dir`` (memory without one);
    the modules' signals start at ``now``.

    ``baud``, ``bit_error_rate`` and ``seed`` override the site file's values. Modules with a
    real ``source`` read it through ``sensors`` (whose acquisition task the caller runs).
    """
    baud = baud or site.baud or DEFAULT_BAUD
    seed = seed if seed is not None else site.seed
    master = random.Random(seed)  # seed None: fresh entropy
    noise = site.noise if bit_error_rate is None else bit_error_rate
    core = BusCore(baud, noise, random.Random(master.getrandbits(64)))
    database = EepromDatabase.in_state_dir(state_dir) if state_dir is not None else None
    for entry in site.modules:
        eeprom: EepromStore = (
            database.slot(entry.module_id) if database is not None else MemoryEeprom()
        )
        config = ModuleConfig(
            entry.module_id, variant_for(entry.kind), entry.cycle, slot_time(baud)
        )
        rng = random.Random(master.getrandbits(64))
        if entry.source is not None:
            if sensors is None:
                raise ValueError(f"module {entry.module_id} reads a real sensor: no SensorBank")
            sensor: SensorSource = sensors.sensor(entry.source)
        else:
            assert entry.signal is not None
            sensor = entry.signal.build(now)
        core.add_module(Hctmps1Module(config, sensor, eeprom, rng, now))
    return core, database
