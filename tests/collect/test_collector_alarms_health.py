"""Logger health alarms for real (issue 21): ``sondalog collect`` against a served logger
whose site file's supply drops below a limit and comes back (``health`` ``measure =
"supply"``), and whose small record fills above a ratio until it is erased (``measure =
"memory"``, from ``record status`` after each contact)."""

from __future__ import annotations

from pathlib import Path

from collector_run import cli, collect_log, collecting, events, states, wait_for
from served_logger import configure, serving

SUPPLY, MEMORY = "low supply", "record filling"
SITE = """[logger]
supply = { model = "steps", schedule = [[0, 12.6], [4, 11.0], [8, 12.6]] }
[[logger.analog]]
address = 16
signal = { model = "constant", value = 1.0 }
"""
RULES = f"""[[notify]]
name = "log"
kind = "log"

[[alarm]]
kind = "health"
name = "{SUPPLY}"
measure = "supply"
below = 11.5
clear = 12
notify = ["log"]

[[alarm]]
kind = "health"
name = "{MEMORY}"
measure = "memory"
above = 0.3
notify = ["log"]
"""


def _config(tmp: Path, url: str) -> Path:
    path = tmp / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
        f'[[source]]\nurl = "{url}"\nname = "station"\ninterval = 0.5\ntimeout = 2\n\n' + RULES
    )
    return path


def test_supply_below_its_limit_and_a_filling_record_raise_and_clear(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    store = tmp_path / "store.sqlite"
    supply, memory = (SUPPLY, "000001"), (MEMORY, "000001")
    with serving(tmp_path, "--site", str(site)) as served:
        configure(served)  # channel 1: the supply (type 1), sampled every second
        served.ask("write file record size 512")  # 31 characters a second: 0.3 in ~5 s
        config = _config(tmp_path, served.url)
        with collecting(config):
            wait_for(lambda: states(store).get(memory) == "raised", 30, config, "memory alarm")
            listed = cli("alarms", "list", str(config)).stdout
            assert any(MEMORY in x and " raised " in x for x in listed.splitlines()), listed
            served.ask("write record status clear")  # the record erased: 0 % full
            wait_for(lambda: states(store).get(memory) == "cleared", 20, config, "memory clear")
            wait_for(lambda: states(store).get(supply) == "cleared", 30, config, "supply clear")
    low = events(store, SUPPLY)
    assert [w for w, _, _ in low] == ["raised", "cleared"], low
    assert low[0][1] == "000001" and low[0][2] == 11.0  # the logger, the low reading
    assert low[1][2] == 12.6
    full = events(store, MEMORY)
    assert [w for w, _, _ in full] == ["raised", "cleared"], full
    assert full[0][2] is not None and 0.3 < full[0][2] < 0.6
    assert full[1][2] is not None and full[1][2] <= 0.3  # erased (maybe a row or two since)
    log = collect_log(config)
    assert "alarm RAISED" in log and SUPPLY in log and MEMORY in log
