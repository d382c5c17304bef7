"""The runner marks a source ``contacting`` only when its contact lasts (issue 24): a contact
of a second or more shows on the dashboard, a quick one writes nothing but its end."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from sondalog.collect.config import CollectorConfig, SourceConfig
from sondalog.collect.delivery import Deliver
from sondalog.collect.runner import CONTACTING_AFTER, Collector


class _Timed:
    """A source whose contact takes ``seconds``."""

    kind = "logger"

    def __init__(self, config: SourceConfig, seconds: float) -> None:
        self.config = config
        self.seconds = seconds

    async def poll(self, deliver: Deliver) -> str:
        await asyncio.sleep(self.seconds)
        await deliver(self.config.name, [], None)
        return "done"


def _collector(tmp_path: Path, seconds: dict[str, float]) -> Collector:
    sources = tuple(
        SourceConfig(name, "tcp://127.0.0.1:9", interval=3600, config_every=0) for name in seconds
    )
    config = CollectorConfig(
        tmp_path / "c.toml", tmp_path / "s.sqlite", True, tmp_path / "b.sqlite", sources, {}
    )
    collector = Collector(config)
    collector.open()
    collector.sources = [_Timed(cfg, seconds[cfg.name]) for cfg in sources]
    return collector


def test_a_long_contact_is_contacting_a_quick_one_never(tmp_path: Path) -> None:
    collector = _collector(tmp_path, {"slow": CONTACTING_AFTER + 0.6, "quick": 0.05})
    marked: list[tuple[str, Any]] = []
    set_state = collector.store.set_state

    def spy(name: str, **state: Any) -> None:
        marked.append((name, state.get("state")))
        set_state(name, **state)

    collector.store.set_state = spy  # type: ignore[method-assign]
    states: list[tuple[Any, Any]] = []

    async def main() -> None:
        stop = asyncio.Event()
        run = asyncio.create_task(collector.run(stop))
        await asyncio.sleep(CONTACTING_AFTER + 0.3)
        states.append((collector.store.source("slow") or {}).get("state"))
        await asyncio.sleep(0.6)
        states.append((collector.store.source("slow") or {}).get("state"))
        stop.set()
        await run

    asyncio.run(main())
    assert states == ["contacting", "ok"]
    assert ("slow", "contacting") in marked
    assert ("quick", "contacting") not in marked


class _Flaky:
    """A source whose contacts take a random few milliseconds and fail now and then."""

    kind = "logger"

    def __init__(self, config: SourceConfig, seed: int) -> None:
        import random

        self.config = config
        self.random = random.Random(seed)
        self.contacts = 0

    async def poll(self, deliver: Deliver) -> str:
        self.contacts += 1
        await asyncio.sleep(self.random.uniform(0, 0.02))
        if self.random.random() < 0.3:
            raise OSError("no answer")
        await deliver(self.config.name, [], None)
        return "done"


def test_every_source_is_contacted_again(tmp_path: Path) -> None:
    """Forty sources every 0.2 s, a third of their contacts failing (retried after 0.1 s):
    all contacted again and again; none stuck."""
    sources = tuple(
        SourceConfig(
            f"s{n}", "tcp://127.0.0.1:9", interval=0.2, retry=0.1, retry_max=0.1, config_every=0
        )
        for n in range(40)
    )
    config = CollectorConfig(
        tmp_path / "c.toml", tmp_path / "s.sqlite", True, tmp_path / "b.sqlite", sources, {}
    )
    collector = Collector(config)
    collector.open()
    flaky = [_Flaky(cfg, n) for n, cfg in enumerate(sources)]
    collector.sources = list(flaky)

    async def main() -> None:
        stop = asyncio.Event()
        run = asyncio.create_task(collector.run(stop))
        await asyncio.sleep(5.0 + 1.2)  # the first contacts spread over 5 s, then 1.2 s more
        stop.set()
        await run

    asyncio.run(main())
    assert min(source.contacts for source in flaky) >= 5
