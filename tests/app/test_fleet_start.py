"""Starting a fleet (issue 24): identities read in threads and written with two syncs of
the file system, each logger's error still named by its entry."""

from __future__ import annotations

import asyncio
import gc
import json
import socket
from pathlib import Path

import pytest

from sondalog.app.fleet import start_fleet
from sondalog.app.fleet_site import FleetLogger
from sondalog.config import ConfigError
from sondalog.io.clock import SteppedClock
from sondalog.io.tcp import free_port_socket


def _fleet(count: int, protocol: str | None = None) -> list[FleetLogger]:
    return [
        FleetLogger(f"S{n:03}", ("127.0.0.1", 0), protocol, where=f"loggers[{n % 2}]")
        for n in range(count)
    ]


def test_a_new_fleet_writes_every_identity_and_a_restart_reads_them(tmp_path: Path) -> None:
    async def start(loggers: list[FleetLogger]) -> list[str]:
        fleet = await start_fleet(loggers, tmp_path, SteppedClock(), None)
        try:
            return [m.engine.identity.version.value for m in fleet.members]
        finally:
            await fleet.close()

    assert asyncio.run(start(_fleet(40, "1.16"))) == ["1.16"] * 40
    for n in range(40):
        path = tmp_path / "loggers" / f"S{n:03}" / "identity.json"
        assert json.loads(path.read_text()) == {"protocol": "1.16", "serial_number": f"S{n:03}"}
        assert path.stat().st_mode & 0o777 == 0o600
    assert asyncio.run(start(_fleet(40))) == ["1.16"] * 40  # protocol from the state


def test_a_logger_whose_state_holds_another_protocol_is_named(tmp_path: Path) -> None:
    asyncio.run(_start_and_close(_fleet(4, "2.10"), tmp_path))
    (tmp_path / "loggers" / "S003" / "identity.json").write_text(
        json.dumps({"protocol": "1.16", "serial_number": "S003"})
    )
    with pytest.raises(ConfigError) as caught:
        asyncio.run(_start_and_close(_fleet(6, "2.10"), tmp_path))
    assert caught.value.field == "loggers[1].protocol"
    assert "holds a protocol 1.16 logger" in str(caught.value)


async def _start_and_close(loggers: list[FleetLogger], state: Path) -> None:
    fleet = await start_fleet(loggers, state, SteppedClock(), None)
    await fleet.close()


def test_port_zero_finds_free_ports_in_turn_and_skips_a_taken_one() -> None:
    """Port 0 (issue 24): the ephemeral ports are tried in turn (the kernel's own search
    costs milliseconds a bind with thousands bound); a port already taken is passed over."""
    first = free_port_socket("127.0.0.1")
    assert first is not None
    port = first.getsockname()[1]
    taken = socket.socket()
    try:
        taken.bind(("127.0.0.1", port + 1))
        taken.listen()
    except OSError:
        pytest.skip("the next port is in use already")
    second = free_port_socket("127.0.0.1")
    assert second is not None
    try:
        assert second.getsockname()[1] not in (port, port + 1)
        assert free_port_socket("localhost") is None  # a host name: the loop binds it
    finally:
        for sock in (first, second, taken):
            sock.close()


def test_every_logger_of_a_fleet_on_port_zero_answers_on_its_own_port(tmp_path: Path) -> None:
    async def run() -> set[bytes]:
        fleet = await start_fleet(_fleet(30), tmp_path, SteppedClock(), None)
        try:
            ports = {m.server.address[1] for m in fleet.members}
            assert len(ports) == 30
            answers = set()
            for port in ports:
                reader, writer = await asyncio.open_connection("127.0.0.1", port)
                writer.write(b"read i snumber\r")
                answers.add(await asyncio.wait_for(reader.readuntil(b"OK\r\n"), 10))
                writer.close()
            return answers
        finally:
            await fleet.close()

    assert asyncio.run(run()) == {f"S{n:03}\r\nOK\r\n".encode() for n in range(30)}


def test_a_running_fleet_is_out_of_the_collectors_sight_until_it_closes(tmp_path: Path) -> None:
    """A full garbage collection over 10,000 loggers' objects stopped the process for about
    a second (issue 24): a started fleet's objects are frozen; closing it thaws them."""

    before = gc.get_threshold()

    async def run() -> tuple[int, int]:
        fleet = await start_fleet(_fleet(5), tmp_path, SteppedClock(), None)
        frozen = gc.get_freeze_count()
        engine = fleet.members[0].engine
        assert all(obj is not engine for obj in gc.get_objects())  # frozen: unseen
        # the collector's own full collections wait for the fleet's periodic one
        assert gc.get_threshold()[2] > 1000
        await fleet.close()
        return frozen, gc.get_freeze_count()

    frozen, after = asyncio.run(run())
    assert frozen > 1000 and after == 0 and gc.get_threshold() == before


def test_a_start_cut_short_before_its_identities_were_in_place_starts_them_anew(
    tmp_path: Path,
) -> None:
    """New identities are written beside their place, synced, then renamed (issue 24): a
    crash between leaves a directory with ``identity.tmp`` only, and that logger is new."""
    (tmp_path / "loggers" / "S001").mkdir(parents=True, mode=0o755)
    (tmp_path / "loggers" / "S001" / "identity.tmp").write_text('{"protocol": "1')
    asyncio.run(_start_and_close(_fleet(3, "1.16"), tmp_path))
    for n in range(3):
        directory = tmp_path / "loggers" / f"S{n:03}"
        assert sorted(p.name for p in directory.iterdir()) == ["identity.json"]
        assert json.loads((directory / "identity.json").read_text())["protocol"] == "1.16"
        assert directory.stat().st_mode & 0o777 == 0o700
