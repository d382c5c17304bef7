"""``sondalog bus config pull|plan|apply`` against served virtual buses (issue 22): real
``bus serve`` subprocesses over TCP and the real CLI."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from bus_helpers import ServedBus, sondalog

LOGGER = [sys.executable, "-m", "sondalog", "logger", "serve"]


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[ServedBus]:
    """A factory-fresh bus: T1 (temp) and H1 (hum)."""
    with ServedBus(tmp_path / "bus") as served:
        yield served


@pytest.fixture
def other(tmp_path: Path) -> Iterator[ServedBus]:
    with ServedBus(tmp_path / "other") as served:
        yield served


def ok(*args: str) -> str:
    done = sondalog(*args)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def configure_by_hand(url: str) -> None:
    """What a technician does with bus config set and bus ask, one setting at a time."""
    ok("bus", "config", url, "T1", "--add-supervisor", "LOG1", "--add-supervisor", "LOG2")
    ok("bus", "config", url, "T1", "--symbol", "TEMP1", "--set-id", "T7", "--save")
    ok("bus", "ask", url, "T7", "AUTOON")
    ok("bus", "config", "set", url, "H1", "--symbol", "HUM", "--save")


def test_round_trip_pull_apply_to_a_factory_bus_pull_again(
    bus: ServedBus, other: ServedBus, tmp_path: Path
) -> None:
    configure_by_hand(bus.url)
    pulled = tmp_path / "modules.toml"
    ok("bus", "config", "pull", bus.url, "-o", str(pulled))
    text = pulled.read_text()
    assert '[[module]]\naddress = "T7"' in text
    assert 'supervisors = ["LOG1", "LOG2"]' in text
    assert 'symbol = "TEMP1"' in text and 'symbol = "HUM"' in text
    assert "autonomous = true" in text
    assert "# ADDSUP/DELSUP/LISTSUP" in text  # comments cite the command table
    assert "password" not in text.split("\n[[")[1]  # never pulled: it cannot be read

    # The factory bus has T1 where the configured one has T7: the file says so.
    wanted = tmp_path / "wanted.toml"
    wanted.write_text(text.replace('address = "T7"', 'address = "T7"\nwas = "T1"'))
    done = sondalog("bus", "config", "plan", other.url, str(wanted))
    assert done.returncode == 1, done.stderr
    assert "T7 (now T1): address: T1 -> T7" in done.stdout
    assert "T7 (now T1): supervisors: (none) -> LOG1, LOG2" in done.stdout
    assert "H1: symbol: (none) -> HUM" in done.stdout
    out = ok("bus", "config", "apply", other.url, str(wanted), "--yes")
    assert "apply: 2 changed, 0 unchanged, 0 failed" in out

    again = tmp_path / "again.toml"
    ok("bus", "config", "pull", other.url, "-o", str(again))
    assert again.read_text() == text
    # The EEPROM holds it: the module answers at T7 with the settings after a restart.
    other.terminate()
    with ServedBus(tmp_path / "other") as restarted:
        after = ok("bus", "config", "pull", restarted.url, "--address", "T7")
        assert 'supervisors = ["LOG1", "LOG2"]' in after
        assert "autonomous =" not in after  # RAM: off after power-up, as the file's comment says


def test_plan_and_apply_are_idempotent(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text(
        '[[module]]\naddress = "T1"\nsupervisors = ["A", "B", "C"]\nsymbol = "S1"\n'
        '\n[[module]]\naddress = "H1"\nautonomous = true\n'
    )
    assert sondalog("bus", "config", "plan", bus.url, str(wanted)).returncode == 1
    ok("bus", "config", "apply", bus.url, str(wanted), "--yes")
    done = sondalog("bus", "config", "plan", bus.url, str(wanted))
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.splitlines() == [
        "T1: unchanged",
        "H1: unchanged",
        "plan: 0 settings to change on 0 modules, 2 unchanged",
    ]
    assert ok("bus", "config", "apply", bus.url, str(wanted), "--yes") == "nothing to change\n"

    # Changing the file: only the differences are written, deletions first.
    wanted.write_text(
        '[[module]]\naddress = "T1"\nsupervisors = ["C", "D"]\n'
        '\n[[module]]\naddress = "H1"\nautonomous = true\n'
    )
    done = sondalog("bus", "config", "plan", bus.url, str(wanted))
    assert done.returncode == 1
    assert done.stdout.splitlines()[:3] == [
        "T1: symbol: S1 -> (none)",
        "T1: supervisors: A, B, C -> C, D",
        "H1: unchanged",
    ]
    out = ok("bus", "config", "apply", bus.url, str(wanted), "--yes")
    assert "T1: applied supervisors: A, B, C -> C, D" in out
    assert "apply: 1 changed, 1 unchanged, 0 failed" in out
    listing = ok("bus", "config", "pull", bus.url, "--address", "T1", "--all")
    assert 'supervisors = ["C", "D"]' in listing and 'symbol = ""' in listing
    assert sondalog("bus", "config", "plan", bus.url, str(wanted)).returncode == 0


def test_a_file_pulled_with_all_applies_as_no_change(bus: ServedBus, tmp_path: Path) -> None:
    full = tmp_path / "full.toml"
    ok(
        "bus",
        "config",
        "pull",
        bus.url,
        "--address",
        "T1",
        "--address",
        "H1",
        "--all",
        "-o",
        str(full),
    )
    assert "autonomous = false" in full.read_text()
    assert sondalog("bus", "config", "plan", bus.url, str(full)).returncode == 0


def test_an_unreachable_module_fails_alone(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text(
        '[[module]]\naddress = "T1"\nsymbol = "S1"\n\n[[module]]\naddress = "T9"\nwas = "T8"\n'
    )
    done = sondalog("bus", "config", "plan", bus.url, str(wanted))
    assert done.returncode == 2
    assert "T1: symbol: (none) -> S1" in done.stdout
    assert f"{wanted}:6: module[1].address: no module answers at T9 nor at T8 (was)" in done.stderr

    done = sondalog("bus", "config", "apply", bus.url, str(wanted), "--yes")
    assert done.returncode == 1
    assert "T1: applied symbol: (none) -> S1" in done.stdout
    assert "T9: FAILED" in done.stdout and "no module answers at T9" in done.stdout
    assert "apply: 1 changed, 0 unchanged, 1 failed" in done.stdout
    assert 'symbol = "S1"' in ok("bus", "config", "pull", bus.url, "--address", "T1")


def test_a_wrong_password_writes_nothing(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text('[[module]]\naddress = "T1"\nsymbol = "S1"\n')
    done = sondalog("bus", "config", "apply", bus.url, str(wanted), "--yes", "--password", "9999")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "T1: FAILED" in done.stdout
    assert "T1: CONNECT got no reply: wrong password (give it with --password)" in done.stdout
    assert "T1: nothing written" in done.stdout
    assert "symbol =" not in ok("bus", "config", "pull", bus.url, "--address", "T1")


def test_the_password_is_set_from_the_file_and_checked(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text('[[module]]\naddress = "T1"\npassword = "s3cret"\nsymbol = "S1"\n')
    done = sondalog("bus", "config", "plan", bus.url, str(wanted))
    assert done.returncode == 1
    assert "T1: password: (another) -> (the file's)" in done.stdout
    out = ok("bus", "config", "apply", bus.url, str(wanted), "--yes")
    assert "T1: the new password opens <connect>" in out
    assert sondalog("bus", "config", "plan", bus.url, str(wanted)).returncode == 0
    refused = sondalog("bus", "config", "pull", bus.url, "--address", "T1")
    assert refused.returncode == 1 and "wrong password" in refused.stderr
    pulled = sondalog("bus", "config", "pull", bus.url, "--address", "T1", "--password", "s3cret")
    assert pulled.returncode == 0 and 'symbol = "S1"' in pulled.stdout


def test_a_file_of_another_variant_is_refused_before_anything_is_written(
    bus: ServedBus, tmp_path: Path
) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text(
        '[[module]]\naddress = "T1"\nsymbol = "S1"\n'
        '\n[[module]]\naddress = "H1"\nvariant = "temp"\nsymbol = "S2"\n'
    )
    done = sondalog("bus", "config", "apply", bus.url, str(wanted), "--yes")
    assert done.returncode == 2
    assert f"{wanted}:7: module[1].variant: H1 is a hum server, not temp" in done.stderr
    assert "nothing was written" in done.stderr
    assert "symbol =" not in ok("bus", "config", "pull", bus.url, "--address", "T1")


def test_a_renamed_module_needs_was(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text('[[module]]\naddress = "T7"\n')
    done = sondalog("bus", "config", "plan", bus.url, str(wanted))
    assert done.returncode == 2 and "no module answers at T7" in done.stderr
    assert 'say where it answers now: was = "ID"' in done.stderr
    # An address that another module holds is that module: with the variant, the clash shows.
    wanted.write_text('[[module]]\naddress = "H1"\nwas = "T1"\nvariant = "temp"\n')
    done = sondalog("bus", "config", "apply", bus.url, str(wanted), "--yes")
    assert done.returncode == 2 and "H1 is a hum server, not temp" in done.stderr
    wanted.write_text('[[module]]\naddress = "T1"\nsymbol = "S1"\n')
    ok("bus", "config", "pull", bus.url, "--address", "T1", "--address", "T1", "-o", str(wanted))
    assert wanted.read_text().count("[[module]]") == 1  # pulled once, and read back fine
    assert sondalog("bus", "config", "plan", bus.url, str(wanted)).returncode == 0


def test_apply_asks_first_without_yes(bus: ServedBus, tmp_path: Path) -> None:
    wanted = tmp_path / "modules.toml"
    wanted.write_text('[[module]]\naddress = "T1"\nsymbol = "S1"\n')
    command = [sys.executable, "-m", "sondalog", "bus", "config", "apply", bus.url, str(wanted)]
    no = subprocess.run(command, input="n\n", capture_output=True, text=True, timeout=30)
    assert no.returncode == 1 and "T1: symbol: (none) -> S1" in no.stdout
    assert "Apply these changes?" in no.stdout and "not applied" in no.stderr
    assert "symbol =" not in ok("bus", "config", "pull", bus.url, "--address", "T1")
    yes = subprocess.run(command, input="y\n", capture_output=True, text=True, timeout=30)
    assert yes.returncode == 0 and "T1: applied symbol: (none) -> S1" in yes.stdout


def test_bad_input_is_a_usage_error(bus: ServedBus, tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[[module]]\naddress = "T1"\nsymbol = "no way"\n')
    for verb in ("plan", "apply"):
        done = sondalog("bus", "config", verb, bus.url, str(bad))
        assert done.returncode == 2
        assert f"{bad}:3: module[0].symbol:" in done.stderr
    missing = sondalog("bus", "config", "plan", bus.url, str(tmp_path / "none.toml"))
    assert missing.returncode == 2
    assert sondalog("bus", "config", "pull", "ftp://x", "--address", "T1").returncode == 2
    assert sondalog("bus", "config", "pull", bus.url, "--address", "T*").returncode == 2
    good = tmp_path / "good.toml"
    good.write_text('[[module]]\naddress = "T1"\n')
    gone = sondalog("bus", "config", "plan", "tcp://127.0.0.1:1", str(good))
    assert gone.returncode == 2 and "cannot reach the bus" in gone.stderr


def test_a_logger_url_is_named_as_no_bus(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [*LOGGER, "--listen", "127.0.0.1:0", "--state", str(tmp_path / "logger")],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
    )
    assert proc.stdout is not None
    try:
        url = "tcp://" + proc.stdout.readline().decode().removeprefix("listening on ").strip()
        wanted = tmp_path / "modules.toml"
        wanted.write_text('[[module]]\naddress = "T1"\n')
        done = sondalog("bus", "config", "plan", url, str(wanted))
        assert done.returncode == 2
        assert "the peer answers, but not with HCTMPS1 frames" in done.stderr
        assert "not an HCTMPS1 bus" in done.stderr
        pulled = sondalog("bus", "config", "pull", url, "--address", "T1")
        assert pulled.returncode == 1 and "not an HCTMPS1 bus" in pulled.stderr
    finally:
        proc.kill()
        proc.wait(timeout=10)
        proc.stdout.close()
