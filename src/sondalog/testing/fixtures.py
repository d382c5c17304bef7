"""The pytest fixtures of ``sondalog.testing`` (docs/testing.md).

``sondalog_site`` is the factory the others are made with: ``sondalog_site(SITE)`` starts a
site file (a :class:`~pathlib.Path`) or site TOML text (a ``str``) and returns its
:class:`~sondalog.testing.handles.SiteHandle`; ``process=True`` runs it as a ``sondalog
serve`` subprocess. Everything it started is stopped when the test ends.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Protocol

import pytest

from sondalog.testing.handles import DeviceHandle, SiteHandle
from sondalog.testing.runners import InProcessRunner, ProcessRunner
from sondalog.testing.sites import BUS_SITE, GSM_SITE, LOGGER_SITE


class SiteFactory(Protocol):
    def __call__(self, site: Path | str, *, process: bool = False) -> SiteHandle: ...


@pytest.fixture
def sondalog_site(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SiteFactory]:
    """Start sites for this test: ``sondalog_site(Path("site.toml"))`` or
    ``sondalog_site("[logger]\\n...")``; ``process=True`` as a subprocess."""
    started: list[InProcessRunner | ProcessRunner] = []

    def start(site: Path | str, *, process: bool = False) -> SiteHandle:
        folder = tmp_path_factory.mktemp("sondalog")
        if isinstance(site, str):
            path = folder / "site.toml"
            path.write_text(site, encoding="utf-8")
        else:
            path = site.resolve()
        runner: Callable[[Path, Path], InProcessRunner | ProcessRunner]
        runner = ProcessRunner if process else InProcessRunner
        started.append(runner(path, folder / "state"))
        return started[-1].handle

    yield start
    for runner in reversed(started):
        runner.close()


@pytest.fixture
def sondalog_logger(sondalog_site: SiteFactory) -> DeviceHandle:
    """A virtual ALA1 logger in the test process (simulated sensors: supply 12.6 V, an analog
    input at address 16 reading 0.5): ``url``, ``step(...)``, ``set(...)``."""
    return sondalog_site(LOGGER_SITE).logger


@pytest.fixture
def sondalog_logger_process(sondalog_site: SiteFactory) -> DeviceHandle:
    """The same logger served by a ``sondalog serve`` subprocess."""
    return sondalog_site(LOGGER_SITE, process=True).logger


@pytest.fixture
def sondalog_bus(sondalog_site: SiteFactory) -> DeviceHandle:
    """An RS-485 bus with two HCTMPS1 modules (T1: 21.0 °C, H1: 45 %RH) in the test process."""
    return sondalog_site(BUS_SITE).bus


@pytest.fixture
def sondalog_gsm(sondalog_site: SiteFactory) -> SiteHandle:
    """A GSM world in the test process: a logger driving modem +420600000001 (``site.logger``,
    ``site["modem:+420600000001"]``), the network's HTTP API (``site.gsm``) and a phone
    +420700000001."""
    return sondalog_site(GSM_SITE)
