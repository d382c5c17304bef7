"""The plugin's parts (issue 23): the clock a test steps, the in-process site, the handles'
controls, the subprocess's announcements, and fixtures that stop what they started."""

from __future__ import annotations

import asyncio
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client import Ala1Client
from sondalog.io.clock_control import ControlledClock
from sondalog.testing import (
    BUS_SITE,
    LOGGER_SITE,
    ControlError,
    ControlUnavailable,
    DeviceHandle,
    SiteFactory,
    UnknownInput,
    running_site,
)
from sondalog.testing.runners import parse_announcement

ROOT = Path(__file__).resolve().parents[2]
SETUP = (
    "write file record size 65536 write channel max number 1",
    "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
    "write channel 1 format 0.2 write channel 1 sampling period 0010",
)


@settings(max_examples=20)
@given(st.floats(1, 1e6), st.floats(0, 2))
def test_a_step_past_a_deadline_wakes_the_sleeper_at_once(wait: float, past: float) -> None:
    async def go() -> None:
        clock = ControlledClock()
        sleeper = asyncio.ensure_future(clock.sleep_until(clock.now() + wait))
        await asyncio.sleep(0)
        assert not sleeper.done()
        clock.step(wait + past)
        await asyncio.wait_for(sleeper, 1.0)  # not `wait` seconds of real time

    asyncio.run(go())


def test_a_step_short_of_a_deadline_leaves_the_sleeper_asleep() -> None:
    async def go() -> None:
        clock = ControlledClock()
        sleeper = asyncio.ensure_future(clock.sleep_until(clock.now() + 3600))
        await asyncio.sleep(0)
        clock.step(1800)
        await asyncio.sleep(0.05)
        assert not sleeper.done()
        clock.step(1800)
        await asyncio.wait_for(sleeper, 1.0)
        with pytest.raises(ValueError):
            clock.step(-1)

    asyncio.run(go())


@settings(max_examples=6)
@given(st.lists(st.integers(1, 240), min_size=1, max_size=4))
def test_every_sample_of_the_steps_is_taken(
    tmp_path_factory: pytest.TempPathFactory, minutes: list[int]
) -> None:
    """Liveness: however the time is cut into steps, a step returns with every sample it made
    due in the record (a sample every 10 minutes, from the configuration on)."""

    async def go() -> tuple[str, ...]:
        async with running_site(LOGGER_SITE, tmp_path_factory.mktemp("site")) as site:
            client = await Ala1Client.connect(site.urls["logger"], timeout=5)
            try:
                for line in SETUP:
                    (await client.command(line)).raise_for_error()
                for step in minutes:
                    await site.step(60 * step)
                return (await client.command("read record 1000 from start")).lines
            finally:
                await client.close()

    rows = asyncio.run(go())
    assert len(rows) == sum(minutes) // 10 + 1
    assert rows[-1].startswith(f"2000010{1 + sum(minutes) // 1440}")


def test_handles_control_through_the_control_api_and_say_what_they_refuse(
    sondalog_logger: DeviceHandle, sondalog_site: SiteFactory
) -> None:
    with pytest.raises(
        UnknownInput, match=r"has no input analog:99 \(its inputs: supply, analog:16"
    ):
        sondalog_logger.set("analog:99", 1.0)
    with pytest.raises(ControlError) as caught:
        sondalog_logger.fault("analog:16", "melted")
    assert caught.value.status == 400 and caught.value.field == "kind"
    with pytest.raises(ValueError, match="backwards"):
        sondalog_logger.step(minutes=-1)
    bus = sondalog_site(BUS_SITE).bus
    with pytest.raises(ControlError, match="the bus has no cut fault"):
        bus.fault("cut")
    bus.fault("module:T1", "disconnected")
    assert bus.describe()["inputs"] == {"module:T1": None, "module:H1": 45.0}
    with pytest.raises(ControlUnavailable, match="no controls"):
        DeviceHandle("modem:+420600000001", "tcp://127.0.0.1:1", bus.control).fault("cut")
    # a subprocess: sondalog serve --control on a free port, the same handle
    process = sondalog_site(LOGGER_SITE, process=True)
    assert process.api.url.startswith("http://127.0.0.1:")
    process.pause()
    before = process.api.time()["now"]
    process.step(hours=6)
    assert process.api.time()["now"] == before + 6 * 3600
    process.logger.fault("power_loss")
    assert process.logger.describe()["powered"] is False
    assert process.logger.clear(kind="power_loss") == [{"kind": "power_loss"}]
    process.logger.set("supply", 11.0)
    assert process.logger.describe()["inputs"]["supply"] == 11.0
    with pytest.raises(KeyError, match="the site has no 'bus'; it has logger"):
        _ = process.bus


def test_a_bad_site_is_refused_with_its_field(sondalog_site: SiteFactory) -> None:
    with pytest.raises(Exception, match=r"site.toml:2: logger.supplyy"):
        sondalog_site("[logger]\nsupplyy = 12\n")


def test_announcements_of_sondalog_serve() -> None:
    assert parse_announcement("logger 000001 listening on 127.0.0.1:10001") == {
        "logger": "tcp://127.0.0.1:10001"
    }
    assert parse_announcement("bus listening on [::1]:5") == {"bus": "tcp://[::1]:5"}
    assert parse_announcement("gsm API on http://127.0.0.1:8025") == {
        "gsm": "http://127.0.0.1:8025"
    }
    assert parse_announcement("gsm modem +420600000001 listening on 127.0.0.1:7") == {
        "modem:+420600000001": "tcp://127.0.0.1:7"
    }
    assert parse_announcement("control API on http://127.0.0.1:9") == {
        "control": "http://127.0.0.1:9"
    }
    assert parse_announcement("logger pty /tmp/a -> /dev/pts/3") == {}


INNER = """
import os
from pathlib import Path

def test_start_both(sondalog_logger, sondalog_logger_process, sondalog_bus):
    urls = [sondalog_logger.url, sondalog_logger_process.url, sondalog_bus.url]
    Path(os.environ["URLS"]).write_text("\\n".join(urls))
"""


def _refused(url: str) -> bool:
    host, _, port = url.removeprefix("tcp://").rpartition(":")
    try:
        socket.create_connection((host, int(port)), timeout=2).close()
    except ConnectionRefusedError:
        return True
    return False


def test_the_fixtures_stop_what_they_started(tmp_path: Path) -> None:
    (tmp_path / "test_inner.py").write_text(INNER)
    urls = tmp_path / "urls.txt"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "URLS": str(urls)}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "sondalog.testing", "-p", "no:cacheprovider",
         "-q", str(tmp_path / "test_inner.py")],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    served = urls.read_text().split()
    assert len(served) == 3
    deadline = time.monotonic() + 10
    while not all(_refused(url) for url in served):
        assert time.monotonic() < deadline, served
        time.sleep(0.1)


def test_a_site_files_scenario_runs_in_the_fixtures(sondalog_site: SiteFactory) -> None:
    """The [[scenario]] of a site started by the plugin runs on its clock: a step stops at it."""
    site = sondalog_site(
        LOGGER_SITE
        + '\n[[scenario]]\nafter = "1h"\naction = "set"\ninput = "analog:16"\nvalue = 0.8\n'
    )
    site.pause()
    assert site.logger.describe()["inputs"]["analog:16"] == 0.5
    site.step(minutes=59)
    assert site.logger.describe()["inputs"]["analog:16"] == 0.5
    site.step(minutes=1)
    assert site.logger.describe()["inputs"]["analog:16"] == 0.8
