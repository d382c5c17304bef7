"""Starting a site for a test: in the test process, or as a ``sondalog serve`` subprocess.

In the test process the site runs on an event loop of its own thread (a test calls the
blocking :class:`sondalog.client.Client` from its own thread, and an async test keeps its own
loop free): :class:`InProcessRunner`. As a subprocess: :class:`ProcessRunner`, which starts
``sondalog serve --control`` on a free loopback port and reads the addresses from the lines it
prints. Either way the handles' controls go through the site's control API
(:class:`~sondalog.client.control.ControlClient`). An async test that wants the site in its
own event loop uses :func:`sondalog.testing.running_site` instead.
"""

from __future__ import annotations

import asyncio
import os
import select
import subprocess
import sys
import threading
import time
from collections.abc import Coroutine
from pathlib import Path
from typing import Any, TypeVar

from sondalog.app.inprocess import InProcessSite, start_inprocess
from sondalog.app.site import SitePlan, load_site
from sondalog.client.control import ControlClient
from sondalog.testing.handles import DeviceHandle, SiteHandle

T = TypeVar("T")
#: Seconds a site may take to start (a loaded CI machine).
START_TIMEOUT = 60.0


class _LoopThread:
    """An event loop running in a thread of its own."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, name="sondalog", daemon=True)
        self._thread.start()

    def run(self, coro: Coroutine[Any, Any, T], timeout: float = START_TIMEOUT) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout)

    def close(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(10)
        self.loop.close()


class InProcessRunner:
    """A site served in this process, its control API on a loopback port of its own."""

    def __init__(self, site: Path, state: Path) -> None:
        self._thread = _LoopThread()
        try:
            self.site: InProcessSite = self._thread.run(start_inprocess(site, state))
        except BaseException:
            self._thread.close()
            raise
        self._api = ControlClient(self.site.control_url)
        names = self.site.names
        self.handle = SiteHandle(
            {
                name: DeviceHandle(name, url, self, names.get(name))
                for name, url in self.site.urls.items()
            },
            self,
            str(state),
        )

    @property
    def api(self) -> ControlClient:
        return self._api

    def step(self, seconds: float) -> None:
        self._thread.run(self.site.step(seconds))  # (it waits for the GSM network too)

    def close(self) -> None:
        self._api.close()
        try:
            self._thread.run(self.site.close())
        finally:
            self._thread.close()


class ProcessRunner:
    """A site served by a ``sondalog serve SITE --state STATE`` subprocess."""

    def __init__(self, site: Path, state: Path) -> None:
        expected = _announced(load_site(site)) | {"control"}
        self.log = state.parent / f"{state.name}.log"
        self._log = self.log.open("ab")
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "sondalog",
                "serve",
                str(site),
                "--state",
                str(state),
                "--control",
                "127.0.0.1:0",
            ],
            stdout=subprocess.PIPE,
            stderr=self._log,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
            # unbuffered: select() below sees the pipe, and a line read ahead into a buffer
            # would be invisible to it (serve prints its addresses in one burst)
            bufsize=0,
        )
        try:
            urls = self._read_urls(expected)
        except BaseException:
            self.close()
            raise
        self._api = ControlClient(urls.pop("control"))
        names = {d["name"] for d in self._api.devices()}
        self.handle = SiteHandle(
            {
                name: DeviceHandle(name, url, self, name if name in names else None)
                for name, url in urls.items()
            },
            self,
            str(state),
        )

    def _read_urls(self, expected: set[str]) -> dict[str, str]:
        assert self.proc.stdout is not None
        urls: dict[str, str] = {}
        deadline = time.monotonic() + START_TIMEOUT
        while not expected <= urls.keys():
            wait = deadline - time.monotonic()
            ready = select.select([self.proc.stdout], [], [], max(0.0, wait))[0]
            line = self.proc.stdout.readline().decode(errors="replace") if ready else ""
            if not line:
                self._log.flush()
                raise RuntimeError(
                    f"sondalog serve did not start (waiting for {sorted(expected - urls.keys())}):"
                    f" {self.log.read_text(errors='replace')[-2000:]}"
                )
            urls.update(parse_announcement(line.strip()))
        return urls

    @property
    def api(self) -> ControlClient:
        return self._api

    def step(self, seconds: float) -> None:
        self._api.step(seconds)

    def close(self) -> None:
        if hasattr(self, "_api"):
            self._api.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._log.close()


def _announced(plan: SitePlan) -> set[str]:
    """The devices whose address ``sondalog serve`` prints for ``plan``."""
    names = set()
    if plan.logger is not None:
        names.add("logger")
    if plan.bus is not None:
        names.add("bus")
    if plan.gsm is not None:
        names.add("gsm")
        names |= {f"modem:{m.number}" for m in plan.gsm.modems if m.listen is not None}
    return names


def parse_announcement(line: str) -> dict[str, str]:
    """The device and URL an announcement line of ``sondalog serve`` names, if any."""
    words = line.split()
    if line.startswith("logger ") and words[2:4] == ["listening", "on"]:
        return {"logger": f"tcp://{words[4]}"}
    if line.startswith("bus listening on "):
        return {"bus": f"tcp://{words[3]}"}
    if line.startswith("control API on "):
        return {"control": words[3]}
    if line.startswith("gsm API on "):
        return {"gsm": words[3]}
    if line.startswith("gsm modem ") and words[3:5] == ["listening", "on"]:
        return {f"modem:{words[2]}": f"tcp://{words[5]}"}
    return {}
