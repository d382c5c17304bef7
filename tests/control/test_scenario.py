"""A site's ``[[scenario]]`` (issue 23): reading the entries, the pure schedule, and the
scenario run on a served site across pause, speed and step of the control clock."""

from __future__ import annotations

import asyncio
import re
from datetime import datetime, time
from pathlib import Path

import pytest
from control_site import SITE, START
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.app.control_actions import Fault, Pause, Resume, SetInput, Speed, Step, parse_duration
from sondalog.app.control_openapi import openapi
from sondalog.app.scenario import Schedule, parse_at, resolve_at
from sondalog.app.scenario_run import site_control
from sondalog.app.serve import start_site
from sondalog.app.site import load_site, with_scenario
from sondalog.config import ConfigError
from sondalog.io.clock_control import ControlledClock


def _site(tmp_path: Path, scenario: str, base: str = SITE) -> Path:
    path = tmp_path / "site.toml"
    path.write_text(base + scenario)
    return path


# -- reading ---------------------------------------------------------------------------------


def test_entries_become_typed_actions_with_their_time(tmp_path: Path) -> None:
    plan = load_site(_site(tmp_path, """
[[scenario]]
at = "03:00"
action = "fault"
kind = "disconnected"
input = "analog:16"

[[scenario]]
after = "2h30m"
action = "set"
input = "supply"
value = 11.5

[[scenario]]
at = 2007-03-02T06:00:00
action = "fault"
kind = "power_loss"
duration = "30m"
"""))  # fmt: skip
    first, second, third = plan.scenario
    assert first.at == time(3, 0) and first.clock == "logger"
    assert first.action == Fault("logger", "disconnected", "analog:16")
    assert second.after == 9000.0 and isinstance(second.action, SetInput)
    assert third.at == datetime(2007, 3, 2, 6) and third.action.duration == 1800.0  # type: ignore[union-attr]
    lines = (tmp_path / "site.toml").read_text().splitlines()
    line = lines.index('action = "fault"') + 1
    assert first.where == f"site.toml:{line}"
    assert first.describe() == "fault disconnected on logger analog:16"


@pytest.mark.parametrize(
    ("entry", "field", "message"),
    [
        ('at = "25:00"\naction = "restart"', "scenario[0].at", "module time"),
        ('after = 60\nat = "01:00"\naction = "restart"', "scenario[0].at", "exactly one"),
        ('action = "restart"', "scenario[0].at", "exactly one"),
        ('after = "soon"\naction = "restart"', "scenario[0].after", "duration like"),
        ('after = -5\naction = "restart"', "scenario[0].after", "seconds >= 0"),
        ('after = 1\naction = "step"\nseconds = 9', "scenario[0].action", "must be one of"),
        ('after = 1\naction = "restart"\ndevice = "bus"', "scenario[0].device", "no device"),
        ('after = 1\naction = "fault"\nkind = "melted"', "scenario[0].kind", "must be one of"),
        ('after = 1\naction = "restart"\ncolour = 1', "scenario[0].colour", "unknown"),
        ('after = 1\naction = "fault"\nkind = "cut"\nduration = 0', "scenario[0].duration", "> 0"),
    ],
)
def test_a_bad_entry_is_refused_naming_file_line_and_field(
    tmp_path: Path, entry: str, field: str, message: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        load_site(_site(tmp_path, f"\n[[scenario]]\n{entry}\n"))
    assert caught.value.field == field
    assert message in caught.value.message
    assert str(caught.value).startswith(f"{tmp_path / 'site.toml'}:")


def test_another_files_scenario_replaces_the_sites(tmp_path: Path) -> None:
    plan = load_site(_site(tmp_path, '\n[[scenario]]\nafter = 1\naction = "restart"\n'))
    other = tmp_path / "night.toml"
    other.write_text('[[scenario]]\nafter = 7\naction = "restart"\n')
    assert [s.after for s in with_scenario(plan, other).scenario] == [7.0]
    other.write_text('[[scenaro]]\nafter = 7\naction = "restart"\n')
    with pytest.raises(ConfigError, match="did you mean"):
        with_scenario(plan, other)


def test_times_and_durations() -> None:
    assert parse_at("3:00") == time(3) and parse_at("23:59:59") == time(23, 59, 59)
    assert parse_at("2007-03-02 03:00") == datetime(2007, 3, 2, 3)
    for bad in ("24:00", "3", "2007-03-02", "noon"):
        with pytest.raises(ValueError):
            parse_at(bad)
    assert parse_duration("1d2h3m4s") == 93784 and parse_duration("90") == 90
    # /openapi.json describes the same spellings of a fault's duration
    string = openapi()["components"]["schemas"]["Fault"]["properties"]["duration"]["oneOf"][1]
    for text in ("90", "15m", "2h30m", "1d", "1.5h"):
        assert re.fullmatch(string["pattern"].strip("^$"), text) and parse_duration(text) > 0
    assert not re.fullmatch(string["pattern"].strip("^$"), "soon")
    # a time of day is the first one at or after the module time now
    now = datetime(2000, 1, 1, 4, 0, 0)
    assert resolve_at(time(3), now, 100.0) == 100.0 + 23 * 3600
    assert resolve_at(time(4), now, 100.0) == 100.0
    assert resolve_at(datetime(2000, 1, 1, 3), now, 100.0) == 100.0 - 3600  # past: at once


# -- the pure schedule -----------------------------------------------------------------------


@given(
    st.lists(st.integers(0, 50), max_size=30),
    st.lists(st.integers(0, 20), min_size=1, max_size=40),
)
def test_every_step_is_given_exactly_once_in_order_never_early(
    dues: list[int], moves: list[int]
) -> None:
    """A stepped clock (any cut of time into steps, including standing still): each step
    comes once, in (time, file) order, at the first look at or after its time."""
    schedule = Schedule((float(d), i) for i, d in enumerate(dues))
    now, before, given_out = 0.0, float("-inf"), []
    for move in [0, *moves, 10_000]:
        now += move
        for i in schedule.pop_due(now):
            assert before < dues[i] <= now
            given_out.append(i)
        before = now
    assert given_out == sorted(range(len(dues)), key=lambda i: (dues[i], i))
    assert schedule.next_due() is None and len(schedule) == 0


# -- run on a served site --------------------------------------------------------------------

_OPS = st.lists(
    st.one_of(
        st.tuples(st.just("step"), st.integers(0, 900)),
        st.tuples(st.just("pause"), st.just(0)),
        st.tuples(st.just("resume"), st.just(0)),
        st.tuples(st.just("speed"), st.sampled_from([1, 1000, 20_000])),
        st.tuples(st.just("wait"), st.integers(1, 20)),  # milliseconds of real time
    ),
    max_size=12,
)


@settings(
    max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(st.integers(0, 3600), min_size=1, max_size=8), _OPS)
def test_scenario_steps_run_once_in_order_across_pause_speed_and_step(
    tmp_path_factory: pytest.TempPathFactory, afters: list[int], ops: list[tuple[str, int]]
) -> None:
    """Liveness and order on the real controller: whatever the control API does to the clock,
    every step runs exactly once, in order, never before its time; while the clock moves only
    by steps, each runs exactly at its time."""
    folder = tmp_path_factory.mktemp("scenario")
    entries = "".join(
        f'\n[[scenario]]\nafter = {a}\naction = "set"\ninput = "analog:16"\nvalue = {i}\n'
        for i, a in enumerate(afters)
    )
    plan = load_site(_site(folder, entries))

    async def go() -> None:
        clock = ControlledClock(1.0, start=START, paused=True)
        running = await start_site(plan, folder / "state", clock)
        control = site_control(running, clock, plan.scenario, lambda line: None)
        runner = control.scheduled[0]
        stepped_only = all(op != "resume" for op, _ in ops)
        try:
            for op, n in ops:
                if op == "step":
                    await control.apply(Step(float(n)))
                elif op == "pause":
                    await control.apply(Pause())
                elif op == "resume":
                    await control.apply(Resume())
                elif op == "speed":
                    await control.apply(Speed(float(n)))
                else:
                    await asyncio.sleep(n / 1000)
            await control.apply(Pause())
            await control.apply(Step(4000.0))
            await asyncio.sleep(0)
            done = runner.done  # type: ignore[attr-defined]
            order = sorted(range(len(afters)), key=lambda i: (afters[i], i))
            assert [step.index for _, step, _ in done] == order
            assert all(refused is None for _, _, refused in done)
            for ran_at, step, _ in done:
                assert ran_at >= START + afters[step.index]
                if stepped_only:
                    assert ran_at == START + afters[step.index]
            logger = control.logger("logger")
            assert logger.inputs(clock.now())["analog:16"] == float(order[-1])
        finally:
            await control.close()
            await running.close()

    asyncio.run(go())


def test_a_step_that_the_state_refuses_is_announced_and_the_rest_runs(tmp_path: Path) -> None:
    plan = load_site(_site(tmp_path, """
[[scenario]]
after = 10
action = "fault"
kind = "cut"

[[scenario]]
after = 20
action = "fault"
kind = "cut"

[[scenario]]
after = 30
action = "clear"
"""))  # fmt: skip
    said: list[str] = []

    async def go() -> None:
        clock = ControlledClock(1.0, start=START, paused=True)
        running = await start_site(plan, tmp_path / "state", clock)
        control = site_control(running, clock, plan.scenario, said.append)
        try:
            await control.apply(Step(25))
            assert control.logger("logger").faults  # the cut is on
            await control.apply(Step(10))
            assert not control.logger("logger").faults
        finally:
            await control.close()
            await running.close()

    asyncio.run(go())
    assert said[1].startswith("scenario site.toml:") and "refused: " in said[1]
    assert said[2].endswith("clear on logger") and said[3] == "scenario: every step ran"


def test_an_input_the_logger_lacks_is_refused_at_start(tmp_path: Path) -> None:
    plan = load_site(_site(tmp_path, """
[[scenario]]
after = 10
action = "fault"
kind = "stuck"
input = "analog:17"
"""))  # fmt: skip

    async def go() -> None:
        clock = ControlledClock(1.0, start=START, paused=True)
        running = await start_site(plan, tmp_path / "state", clock)
        try:
            with pytest.raises(ConfigError) as caught:
                site_control(running, clock, plan.scenario, lambda line: None)
        finally:
            await running.close()
        assert caught.value.field == "scenario[0].input"
        assert "has no input analog:17" in caught.value.message

    asyncio.run(go())
