"""What a test holds of a device it started: its URL and a control handle (issue 23).

A :class:`DeviceHandle` gives the device's ``url`` (``tcp://127.0.0.1:PORT``; the GSM
network's ``http://...``) and controls it through the control API of its site
(docs/control.md), with the issue's names: ``logger.fault("analog:16", "disconnected")``,
``logger.clear()``, ``logger.step(hours=6)``, ``logger.snapshot("clean")``. A site in the test
process serves that API on a free loopback port of its own, a ``sondalog serve`` subprocess is
started with ``--control`` on one: the same handle either way. A :class:`Control` is what a
handle calls: ``step`` (for a site in the test process it also waits for the GSM network)
and ``api``, a :class:`~sondalog.client.control.ControlClient`, for everything else.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

from sondalog.app.inprocess import UnknownInput
from sondalog.client.control import ControlClient, ControlError


class ControlUnavailable(RuntimeError):
    """The device has no control of that kind (a bus's faults, a GSM modem's inputs)."""


class Control(Protocol):
    """How a handle changes the world its device lives in."""

    def step(self, seconds: float) -> None:
        """Let ``seconds`` of the devices' time pass at once; every sample due is taken."""
        ...

    @property
    def api(self) -> ControlClient:
        """The site's control API."""
        ...


def duration(seconds: float, minutes: float, hours: float, days: float) -> float:
    """The seconds of a duration given in parts; refuses a negative one."""
    total = seconds + 60 * minutes + 3600 * hours + 86400 * days
    if total < 0:
        raise ValueError("time does not run backwards")
    return total


@dataclass
class DeviceHandle:
    """One device of a started site: where it listens and how to control it."""

    name: str
    """``logger``, ``bus``, ``gsm`` (the network's HTTP API), ``modem:NUMBER``, ``fleet:N``."""
    url: str
    control: Control = field(repr=False)
    controlled: str | None = None
    """Its name in the control API (``logger``, ``loggers.SERIAL``, ``gsm``); None: none."""

    @property
    def host(self) -> str:
        return self.url.partition("://")[2].rpartition(":")[0].strip("[]")

    @property
    def port(self) -> int:
        return int(self.url.rpartition(":")[2].rstrip("/"))

    def _device(self) -> str:
        if self.controlled is None:
            raise ControlUnavailable(
                f"{self.name} has no controls in the control API (its devices: loggers, the "
                "GSM network, the mail hub)"
            )
        return self.controlled

    def step(
        self, seconds: float = 0.0, *, minutes: float = 0.0, hours: float = 0.0, days: float = 0.0
    ) -> None:
        """Let time pass at once (the whole site's clock): ``logger.step(hours=6)``."""
        self.control.step(duration(seconds, minutes, hours, days))

    def set(self, what: str, value: float) -> None:
        """Set a simulated input: ``logger.set("analog:16", 0.8)``, ``logger.set("supply",
        11.0)``; a number holds from now on. An input it lacks: :class:`UnknownInput`."""
        try:
            self.control.api.set(self._device(), what, value)
        except ControlError as exc:
            if exc.field == "input":
                raise UnknownInput(exc.message) from None
            raise

    def fault(self, where: str, kind: str | None = None, /, **params: Any) -> dict[str, Any]:
        """Inject a fault: ``logger.fault("analog:16", "disconnected")`` (an input's),
        ``logger.fault("power_loss", duration=1800)``, ``logger.fault("noise", rate=0.01)``
        (the device's); the kinds and their keys are docs/control.md's."""
        kind, input = (where, None) if kind is None else (kind, where)
        if input is not None:
            params["input"] = input
        answer: dict[str, Any] = self.control.api.fault(self._device(), kind, **params)
        return answer

    def clear(self, input: str | None = None, *, kind: str | None = None) -> list[Any]:
        """End faults: all of them, those of ``input`` and/or of ``kind``; the ended ones."""
        answer = self.control.api.clear(self._device(), kind, input)
        return list(answer["cleared"])

    def restart(self) -> None:
        """The logger restarts from its memory (what a reset does)."""
        self.control.api.restart(self._device())

    def snapshot(self, name: str = "default") -> None:
        """Keep the logger's whole state (memory, record, inputs) as ``name``."""
        self.control.api.snapshot(self._device(), name)

    def restore(self, name: str = "default") -> None:
        """Put the state kept as ``name`` back (in milliseconds: a reset between tests)."""
        self.control.api.restore(self._device(), name)

    def describe(self) -> dict[str, Any]:
        """What the control API says of it now: inputs, faults, module time, record rows."""
        return self.control.api.device(self._device())


@dataclass
class SiteHandle:
    """A started site: a handle per device, and the site-wide controls."""

    devices: dict[str, DeviceHandle]
    control: Control = field(repr=False)
    state: str = ""
    """The state directory (non-volatile memories, mailboxes)."""

    def __getitem__(self, name: str) -> DeviceHandle:
        try:
            return self.devices[name]
        except KeyError:
            raise KeyError(
                f"the site has no {name!r}; it has {', '.join(self.devices) or 'nothing'}"
            ) from None

    @property
    def logger(self) -> DeviceHandle:
        return self["logger"]

    @property
    def bus(self) -> DeviceHandle:
        return self["bus"]

    @property
    def gsm(self) -> DeviceHandle:
        """The GSM network (``url``: its HTTP API, for ``sondalog.client.phone``)."""
        return self["gsm"]

    @property
    def api(self) -> ControlClient:
        """The site's control API (``api.url``; every action of docs/control.md)."""
        return self.control.api

    def step(
        self, seconds: float = 0.0, *, minutes: float = 0.0, hours: float = 0.0, days: float = 0.0
    ) -> None:
        """Let time pass at once for every device of the site."""
        self.control.step(duration(seconds, minutes, hours, days))

    def pause(self) -> None:
        """Stop the site's clock: from now on only :meth:`step` moves it."""
        self.control.api.pause()

    def resume(self) -> None:
        self.control.api.resume()

    def speed(self, factor: float) -> None:
        """Run the site's clock ``factor`` times real time."""
        self.control.api.speed(factor)
