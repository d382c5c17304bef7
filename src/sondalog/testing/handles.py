"""What a test holds of a device it started: its URL and a control handle (issue 23).

A :class:`DeviceHandle` gives the device's ``url`` (``tcp://127.0.0.1:PORT``; the GSM
network's ``http://...``) and controls it through a :class:`Control`: the methods keep the
issue's names (``logger.step(hours=6)``, ``logger.set("analog:16", 0.8)``,
``logger.fault("ch2", "disconnected")``). A device started in the test process is
controlled directly (:class:`~sondalog.app.inprocess.InProcessSite`); a subprocess will be
controlled through ``sondalog serve --control`` (its HTTP API) by another :class:`Control`,
with the same handle; until that API is built a subprocess's control says so
(:class:`ControlUnavailable`). Faults need that API in both cases.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol


class ControlUnavailable(RuntimeError):
    """The control asked for is not offered by how the device runs (yet)."""


class Control(Protocol):
    """How a handle changes the world its device lives in."""

    def step(self, seconds: float) -> None:
        """Let ``seconds`` of the devices' time pass at once; every sample due is taken."""
        ...

    def set(self, device: str, what: str, value: float) -> None:
        """Set a simulated input of ``device`` (``supply``, ``analog:16``, ...)."""
        ...

    def fault(self, device: str, where: str, kind: str) -> None:
        """Inject fault ``kind`` at ``where`` of ``device``."""
        ...


#: Why faults are not offered yet (the control API of issue 23 is another part's).
FAULTS_LATER = (
    "faults are injected through the control API (sondalog serve --control), which this "
    "version does not have yet; set an input to an out-of-range value instead"
)


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

    @property
    def host(self) -> str:
        return self.url.partition("://")[2].rpartition(":")[0].strip("[]")

    @property
    def port(self) -> int:
        return int(self.url.rpartition(":")[2].rstrip("/"))

    def step(
        self, seconds: float = 0.0, *, minutes: float = 0.0, hours: float = 0.0, days: float = 0.0
    ) -> None:
        """Let time pass at once (the whole site's clock): ``logger.step(hours=6)``."""
        self.control.step(duration(seconds, minutes, hours, days))

    def set(self, what: str, value: float) -> None:
        """Set a simulated input: ``logger.set("analog:16", 0.8)``, ``logger.set("supply",
        11.0)``; a number holds from now on."""
        self.control.set(self.name, what, value)

    def fault(self, where: str, kind: str) -> None:
        """Inject a fault: ``logger.fault("ch2", "disconnected")`` (needs the control API)."""
        self.control.fault(self.name, where, kind)


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

    def step(
        self, seconds: float = 0.0, *, minutes: float = 0.0, hours: float = 0.0, days: float = 0.0
    ) -> None:
        """Let time pass at once for every device of the site."""
        self.control.step(duration(seconds, minutes, hours, days))
