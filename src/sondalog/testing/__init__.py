"""``sondalog.testing``: the pytest plugin for testing host software against sondalog's
virtual devices (issue 23, docs/testing.md).

Installed with sondalog and registered by the ``pytest11`` entry point, so a test suite only
names the fixtures::

    from sondalog.client import Client

    def test_reads_the_version(sondalog_logger):
        with Client(sondalog_logger.url) as logger:
            assert logger.command("read i version").lines == ("2.10",)

Fixtures (:mod:`sondalog.testing.fixtures`): ``sondalog_logger``, ``sondalog_logger_process``,
``sondalog_bus``, ``sondalog_gsm`` and the factory ``sondalog_site``; each gives handles with
the device's ``url`` and its controls through the site's control API (``step``, ``set``,
``fault``, ``clear``, ``restart``, ``snapshot``, ``restore``; the site's ``pause``, ``resume``,
``speed`` and ``api``: :mod:`sondalog.testing.handles`), in the test process or a subprocess
alike; a refusal raises :class:`ControlError`. An async test that wants the site in its own
event loop uses :func:`running_site`.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from pathlib import Path

from sondalog.app.inprocess import InProcessSite, UnknownInput, start_inprocess
from sondalog.client.control import ControlClient, ControlError
from sondalog.testing.fixtures import (
    SiteFactory,
    sondalog_bus,
    sondalog_gsm,
    sondalog_logger,
    sondalog_logger_process,
    sondalog_site,
)
from sondalog.testing.handles import ControlUnavailable, DeviceHandle, SiteHandle
from sondalog.testing.sites import BUS_SITE, GSM_SITE, LOGGER_SITE

__all__ = [
    "BUS_SITE",
    "GSM_SITE",
    "LOGGER_SITE",
    "ControlClient",
    "ControlError",
    "ControlUnavailable",
    "DeviceHandle",
    "InProcessSite",
    "SiteFactory",
    "SiteHandle",
    "UnknownInput",
    "running_site",
    "sondalog_bus",
    "sondalog_gsm",
    "sondalog_logger",
    "sondalog_logger_process",
    "sondalog_site",
]


@contextlib.asynccontextmanager
async def running_site(site: Path | str, state: Path) -> AsyncIterator[InProcessSite]:
    """A site served in the running event loop (an async test's own): a site file or site
    TOML text; ``urls``, ``await step(seconds)``, ``set_input(what, value)``."""
    if isinstance(site, str):
        state.mkdir(parents=True, exist_ok=True)
        path = state / "site.toml"
        path.write_text(site, encoding="utf-8")
        site = path
    started = await start_inprocess(site, state / "state")
    try:
        yield started
    finally:
        await started.close()
