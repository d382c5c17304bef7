"""Signal models and the bus part of the site file; the SQLite EEPROM."""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import pytest

from sondalog.backends.sim.signals import build_signal
from sondalog.backends.sim.site_bus import default_bus_site, load_bus_site
from sondalog.backends.store.eeprom import FILE_NAME, EepromDatabase
from sondalog.config import ConfigError
from sondalog.hctmps1 import EepromImage, Kind

S = 5000.0  # start time of the simulation


def test_constant_sine_ramp() -> None:
    assert build_signal({"model": "constant", "value": 3}, S)(0) == 3.0
    sine = build_signal({"model": "sine", "mean": 20, "amplitude": 2, "period": 100}, S)
    assert sine(S) == pytest.approx(20)
    assert sine(S + 25) == pytest.approx(22)
    ramp = build_signal({"model": "ramp", "start": 1, "rate": 0.5, "max": 3}, S)
    assert (ramp(S), ramp(S + 2), ramp(S + 100)) == (1.0, 2.0, 3.0)


def test_random_walk_is_reproducible_and_clamped() -> None:
    table = {"model": "random_walk", "start": 50, "step": 5, "seed": 4, "min": 0, "max": 100}
    a, b = build_signal(table, S), build_signal(table, S)
    late = [a(S + 60 * k) for k in range(500)]
    assert late == [b(S + 60 * k) for k in range(500)]
    assert all(0 <= v <= 100 for v in late)
    assert a(S + 30) == a(S) == 50
    assert len(set(late)) > 100


def test_steps_and_csv(tmp_path: Path) -> None:
    steps = build_signal({"model": "steps", "schedule": [[0, 1], [10, 2]]}, S)
    assert (steps(S - 5), steps(S + 9.9), steps(S + 10), steps(S + 1e6)) == (1, 1, 2, 2)
    (tmp_path / "x.csv").write_text("t,v\n0,0\n10,10\n20,0\n")
    csv = build_signal({"model": "csv", "path": "x.csv", "loop": True}, S, tmp_path)
    assert (csv(S + 5), csv(S + 15), csv(S + 25)) == (5, 5, 5)
    held = build_signal({"model": "csv", "path": str(tmp_path / "x.csv"), "interpolate": False}, S)
    assert held(S + 5) == 0


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"model": "wave"}, "model"),
        ({"model": "constant"}, "value"),
        ({"model": "constant", "value": "3"}, "value"),
        ({"model": "constant", "value": True}, "value"),
        ({"model": "constant", "value": 1, "colour": 2}, "colour"),
        ({"model": "sine", "mean": 1, "amplitude": 1, "period": 0}, "period"),
        ({"model": "ramp", "start": 1, "rate": 1, "min": 5, "max": 1}, "min"),
        ({"model": "random_walk", "start": 1, "step": 1, "seed": 1.5}, "seed"),
        ({"model": "steps", "schedule": [[1, 1], [1, 2]]}, "schedule[1]"),
        ({"model": "steps", "schedule": [[1]]}, "schedule[0]"),
        ({"model": "csv", "path": "/nonexistent.csv"}, "path"),
    ],
)
def test_signal_errors_name_the_field(table: dict[str, object], field: str) -> None:
    with pytest.raises(ConfigError) as info:
        build_signal(table, S)
    assert info.value.field == field


def test_bad_csv_rows_are_reported(tmp_path: Path) -> None:
    (tmp_path / "bad.csv").write_text("0,1\n1,x\n")
    with pytest.raises(ConfigError, match="line 2"):
        build_signal({"model": "csv", "path": "bad.csv"}, S, tmp_path)


SITE = """\
# a test site
[logger]
ignored = true

[bus]
baud = 19200
noise = 0.0

[[bus.modules]]
id = "T1"
kind = "temp"
signal = { model = "constant", value = 20.0 }

[[bus.modules]]
id = "H2"
kind = "hum"
cycle = 5
[bus.modules.signal]
model = "sine"
mean = 50
amplitude = 5
period = 600
"""


def test_site_file_is_read(tmp_path: Path) -> None:
    path = tmp_path / "site.toml"
    path.write_text(SITE)
    site = load_bus_site(path)
    assert site.baud == 19200
    assert [(m.module_id, m.kind, m.cycle) for m in site.modules] == [
        ("T1", Kind.TEMP, 10.0),
        ("H2", Kind.HUM, 5.0),
    ]
    assert site.modules[1].signal.build(S)(S + 150) == pytest.approx(55)


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        ("baud = 19200", "baud = -1", ":6: bus.baud"),
        ("noise = 0.0", "noise = 2", ":7: bus.noise"),
        ('id = "T1"', 'id = "T 1"', ":10: bus.modules[0].id"),
        ('id = "H2"', 'id = "T1"', ":15: bus.modules[1].id"),
        ('kind = "hum"', 'kind = "wind"', ":16: bus.modules[1].kind"),
        ("cycle = 5", "cycle = 0.01", ":17: bus.modules[1].cycle"),
        ("period = 600", "period = -600", ":22: bus.modules[1].signal.period"),
        ("value = 20.0", "valeur = 20.0", ":12: bus.modules[0].signal.valeur"),
        ("amplitude = 5", "amplitude = 5\ncolour = 1", ":22: bus.modules[1].signal.colour"),
        ("noise = 0.0", "nois = 0.0", ":7: bus.nois"),
        ("[bus]", "[bus\n", ": toml: "),
    ],
)
def test_site_errors_name_file_field_and_line(
    tmp_path: Path, old: str, new: str, where: str
) -> None:
    path = tmp_path / "site.toml"
    assert old in SITE
    path.write_text(SITE.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_bus_site(path)
    assert str(info.value).startswith(f"{path}{where}")


def test_site_needs_a_bus_with_modules(tmp_path: Path) -> None:
    path = tmp_path / "site.toml"
    path.write_text("[logger]\n")
    with pytest.raises(ConfigError, match="needs a \\[bus\\] table"):
        load_bus_site(path)
    path.write_text("[bus]\nbaud = 9600\n")
    with pytest.raises(ConfigError, match=r":1: bus\.modules"):
        load_bus_site(path)
    with pytest.raises(ConfigError, match="cannot read"):
        load_bus_site(tmp_path / "missing.toml")


def test_default_site() -> None:
    site = default_bus_site()
    assert [(m.module_id, m.kind) for m in site.modules] == [("T1", Kind.TEMP), ("H1", Kind.HUM)]
    assert all(m.signal is not None and not math.isnan(m.signal.build(S)(S)) for m in site.modules)


def test_examples_are_valid() -> None:
    examples = sorted((Path(__file__).parents[2] / "examples").glob("bus-*.toml"))
    assert examples
    for path in examples:
        assert load_bus_site(path).modules


def test_sqlite_eeprom_persists_in_wal_mode(tmp_path: Path) -> None:
    db = EepromDatabase.in_state_dir(tmp_path)
    t1, h1 = db.slot("T1"), db.slot("H1")
    assert t1.load() is None
    t1.save(EepromImage("T9", "pw", ("L1", "L2"), "SYM"))
    t1.save(EepromImage("T8"))
    h1.save(EepromImage("H1", symbol="RH"))
    db.close()
    again = EepromDatabase(tmp_path / FILE_NAME)
    assert again.slot("T1").load() == EepromImage("T8")
    assert again.slot("H1").load() == EepromImage("H1", symbol="RH")
    again.close()
    raw = sqlite3.connect(tmp_path / FILE_NAME)
    assert raw.execute("PRAGMA journal_mode").fetchone() == ("wal",)
    assert raw.execute("SELECT writes FROM eeprom WHERE slot = 'T1'").fetchone() == (2,)
    raw.close()
