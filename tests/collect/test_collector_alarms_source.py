"""A source refusing, for real (issue 21): ``sondalog collect`` with a source whose port
refuses connections raises a ``collector`` rule ``watch = "source"`` after ``for`` failed
contacts in a row, and clears it when a logger answers on that port."""

from __future__ import annotations

from pathlib import Path

from collector_run import cli, collect_log, collecting, events, states, wait_for
from served_logger import configure, serving
from services import free_port

from sondalog.collect.alarms import alarm_id

RULE = "station refusing"


def _config(tmp: Path, port: int) -> Path:
    path = tmp / "collector.toml"
    path.write_text(
        '[sqlite]\npath = "store.sqlite"\n\n[web]\nenabled = false\n\n'
        f'[[source]]\nurl = "tcp://127.0.0.1:{port}"\nname = "station"\ninterval = 0.5\n'
        "timeout = 1\nretry = 0.2\nretry_max = 0.4\n\n"
        '[[notify]]\nname = "log"\nkind = "log"\n\n'
        f'[[alarm]]\nkind = "collector"\nname = "{RULE}"\nwatch = "source"\n'
        'source = "station"\nfor = 3\nnotify = ["log"]\n'
    )
    return path


def test_a_refusing_source_raises_after_for_failures_and_clears_when_it_answers(
    tmp_path: Path,
) -> None:
    port = free_port()  # nothing listens: every contact is refused
    config = _config(tmp_path, port)
    store = tmp_path / "store.sqlite"
    key = (RULE, "station")
    with collecting(config):
        wait_for(lambda: states(store).get(key) == "raised", 20, config, "source alarm")
        (what, subject, count), *_ = events(store, RULE)
        assert (what, subject, count) == ("raised", "station", 3.0)  # the third refusal
        listed = cli("alarms", "list", str(config)).stdout
        line = next(x for x in listed.splitlines() if alarm_id(RULE, "station") in x)
        assert " raised " in line and RULE in line
        with serving(tmp_path, "--listen", f"127.0.0.1:{port}") as served:
            configure(served)
            wait_for(lambda: states(store).get(key) == "cleared", 20, config, "source clear")
    assert [w for w, _, _ in events(store, RULE)] == ["raised", "cleared"]
    log = collect_log(config)
    assert "alarm RAISED" in log and "alarm CLEARED" in log and "refus" in log.lower()
