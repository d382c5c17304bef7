"""Station files of several loggers, and applying one to a fleet (docs/config.md).

A file holds one logger's settings, or several loggers::

    [channel.1]                 # the template: every logger gets these
    sampling_period = "001000"

    [[logger]]
    url = "tcp://10.0.0.7:10001"
    serial_number = "A1-0007"   # checked: the logger at url must be this one
    [logger.identity]           # per-logger overrides, over the template
    name = "Brod"

:func:`read_file` gives one :class:`Target` per logger; :func:`run_fleet` plans or applies
them ``parallel`` at a time, and a failure on one never stops the others.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from pathlib import Path

from sondalog.client.ala1_codec import ClientError
from sondalog.client.endpoints import parse_url
from sondalog.client.station_apply import Explain, Outcome, Plan, Refused, apply, make_plan
from sondalog.client.station_file import Station, check_partition, read_station
from sondalog.config import load

#: The most loggers one file may name.
MAX_LOGGERS = 10_000


@dataclass(frozen=True)
class Target:
    """One logger of a file: where it is and the station it should be."""

    url: str | None  # None: a single-logger file (the URL comes from the command line)
    station: Station


def read_file(path: Path) -> list[Target]:
    """The loggers of station file ``path``; raises ConfigError (file:line:field)."""
    root = load(path)
    template = read_station(root, extra_keys=("logger",), check=False)
    entries = root.tables("logger")
    if not entries:
        check_partition(template, root)
        return [Target(None, template)]
    if len(entries) > MAX_LOGGERS:
        raise root.fail("logger", f"at most {MAX_LOGGERS} loggers in one file")
    targets = []
    seen: dict[str, str] = {}
    for entry in entries:
        url = entry.convert("url", _url)
        if url in seen:
            raise entry.fail("url", f"{url} is also {seen[url]}")
        seen[url] = entry.field("url")
        station = template.merged(read_station(entry, extra_keys=("url",), check=False))
        check_partition(station, entry)
        targets.append(Target(url, station))
    return targets


def _url(text: str) -> str:
    parse_url(text)  # ValueError names what is wrong
    return text


@dataclass(frozen=True)
class Result:
    """One logger's line of a fleet run."""

    url: str
    state: str  # "changed", "unchanged", "would change", "failed"
    detail: str = ""

    def line(self) -> str:
        return f"{self.url}: {self.state}" + (f" ({self.detail})" if self.detail else "")


async def _one(target: Target, url: str, explain: Explain | None) -> Result:
    try:
        if explain is None:
            plan: Plan = await make_plan(url, target.station)
            if plan.empty:
                return Result(url, "unchanged")
            count = len(plan.changes) + (plan.tables is not None)
            return Result(url, "would change", writes(count))
        outcome: Outcome = await apply(url, target.station, explain)
    except Refused as exc:
        return Result(url, "failed", "; ".join(exc.problems))
    except (ClientError, OSError, ValueError) as exc:
        return Result(url, "failed", str(exc) or type(exc).__name__)
    if outcome.error is not None:
        return Result(url, "failed", outcome.error.splitlines()[0])
    if not outcome.applied:
        return Result(url, "unchanged")
    return Result(url, "changed", writes(len(outcome.applied)) + " verified")


async def run_fleet(
    targets: list[Target],
    explain: Explain | None,
    parallel: int,
    report: Callable[[Result], None] = lambda result: None,
) -> list[Result]:
    """Plan (``explain`` None) or apply every target, ``parallel`` at a time; ``report`` is
    called as each finishes."""
    gate = asyncio.Semaphore(max(1, parallel))

    async def run(target: Target) -> Result:
        assert target.url is not None
        async with gate:
            result = await _one(target, target.url, explain)
        report(result)
        return result

    jobs: list[Awaitable[Result]] = [run(t) for t in targets]
    return list(await asyncio.gather(*jobs))


def writes(count: int) -> str:
    """``1 write``, ``3 writes``."""
    return f"{count} write{'' if count == 1 else 's'}"


def summary(results: list[Result]) -> str:
    """``50 loggers: 49 changed, 1 failed`` (states in a fixed order)."""
    order = ("changed", "would change", "unchanged", "failed")
    counts = {state: sum(r.state == state for r in results) for state in order}
    parts = ", ".join(f"{n} {state}" for state, n in counts.items() if n)
    return f"{len(results)} loggers: {parts}"
