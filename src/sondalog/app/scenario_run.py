"""A site's scenario run on the served site (issue 23, docs/control.md "Scenarios").

:func:`start_scenario` resolves when each ``[[scenario]]`` step is due on the site's clock
(``at``: the module time of its logger now, ``after``: from now), checks what a loaded file
could not (the inputs the loggers really have: a :class:`~sondalog.config.ConfigError` with
the entry's file, line and field) and runs the steps through the site's
:class:`~sondalog.app.control.Controller`: a task sleeps on the clock until the next is due,
and a step of the control API stops at each on its way (:class:`~sondalog.app.control.
Scheduled`). Either way the devices first run what fell due up to that moment, then the step
is applied and announced; a step the devices' state refuses then (a fault already active, a
restart without power) is announced as refused and the scenario goes on.
"""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import dataclass, field

from sondalog.app.control import Controller
from sondalog.app.control_actions import Clear, Fault, SetInput, input_kind
from sondalog.app.control_logger import Refusal
from sondalog.app.scenario import ScenarioStep, Schedule, resolve_at
from sondalog.app.serve import Announce, RunningSite
from sondalog.io.clock import Clock


@dataclass
class ScenarioRunner:
    """The steps still to run, the task that runs them, what ran (for tests and logs)."""

    control: Controller
    schedule: Schedule[ScenarioStep]
    announce: Announce
    done: list[tuple[float, ScenarioStep, str | None]] = field(default_factory=list)
    """(site clock time, step, None or why it was refused), in the order they ran."""
    _lock: asyncio.Lock = field(default_factory=asyncio.Lock)
    _task: asyncio.Task[None] | None = None

    def next_due(self) -> float | None:
        return self.schedule.next_due()

    async def run_due(self) -> None:
        """Run every step due now, once each, in order (the devices caught up first)."""
        async with self._lock:
            if (due := self.schedule.next_due()) is None or due > self.control.clock.now():
                return
            await self.control.settle()
            for step in self.schedule.pop_due(self.control.clock.now()):
                await self._run(step)
            if not self.schedule:
                self.announce("scenario: every step ran")

    async def _run(self, step: ScenarioStep) -> None:
        now = self.control.clock.now()
        refused = None
        try:
            await self.control.apply(step.action)
        except Refusal as exc:
            refused = exc.message
        self.done.append((now, step, refused))
        said = f"scenario {step.where}: {step.describe()}"
        self.announce(f"{said}: refused: {refused}" if refused else said)

    async def _loop(self) -> None:
        clock = self.control.clock
        while (due := self.schedule.next_due()) is not None:
            await clock.sleep_until(due)
            await self.run_due()

    def start(self) -> None:
        self._task = asyncio.get_running_loop().create_task(self._loop())

    async def close(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task


def start_scenario(
    control: Controller, steps: list[ScenarioStep], announce: Announce = lambda line: None
) -> ScenarioRunner:
    """Run ``steps`` on ``control``'s site from now (in the running loop); raises
    :class:`~sondalog.config.ConfigError` for a step the site's devices cannot take."""
    now = control.clock.now()
    schedule: Schedule[ScenarioStep] = Schedule()
    for step in steps:
        _check(control, step)
        if step.at is not None:
            assert step.clock is not None
            module_now = control.logger(step.clock).engine.state.module_time(now)
            schedule.add(resolve_at(step.at, module_now, now), step)
        else:
            schedule.add(now + (step.after or 0.0), step)
    runner = ScenarioRunner(control, schedule, announce)
    control.scheduled.append(runner)
    runner.start()
    return runner


def _check(control: Controller, step: ScenarioStep) -> None:
    """The step's device and input exist as the site runs (a loaded file cannot know its
    simulated inputs' names, a fleet's sensors)."""
    action = step.action
    name = action.input if isinstance(action, SetInput | Fault | Clear) else None
    if name is None or step.device not in [*control.loggers, "bus"] or input_kind(name) == "ch":
        return  # (a channel's input is the one it reads when the step runs)
    try:
        if step.device == "bus" and control.bus is not None:
            control.bus.module(name)
        else:
            control.logger(step.device).check_input(name)
    except Refusal as exc:
        raise step.entry.fail("input", exc.message) from None


def site_control(
    site: RunningSite, clock: Clock, steps: list[ScenarioStep], announce: Announce
) -> Controller:
    """The :class:`Controller` of a served site, its scenario (``steps``) started on it."""
    control = Controller(site, clock)
    if steps:
        try:
            start_scenario(control, steps, announce)
        except BaseException:
            control.scheduled.clear()
            raise
    return control
