"""Hardware backends registered by name (python-can's interface pattern; DESIGN.md point 4).

A backend turns a site file into the :class:`~sondalog.ala1.hardware.Hardware` of a logger.
``sim`` (simulated hardware from the site file's ``[logger]`` table) is built in; ``linux``
(1-Wire, IIO, GPIO on a real board) registers itself the same way. A backend module exposes
``create(context) -> Hardware``; it is imported only when chosen, so a missing optional
dependency of one backend never stops another.

A backend whose inputs take time to read implements :class:`Acquiring` too: the runtime runs
its acquisition task, and the core tells it ahead of each sampling instant
(:meth:`Hardware.prepare`), so no backend ever blocks the event loop.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, runtime_checkable

from sondalog.ala1.hardware import Hardware


@dataclass(frozen=True)
class BackendContext:
    """What a backend is built from: the parsed site file and where it came from."""

    site: Mapping[str, object] = field(default_factory=dict)
    path: Path | None = None
    text: str | None = None
    start: float = 0.0  # host-clock time the backend starts at
    root: Path = Path("/")  # file-system root of sysfs and /dev (tests use a temp dir)
    speed: float = 1.0  # the clock's --speed (a real board's backend refuses anything but 1)


@runtime_checkable
class Acquiring(Protocol):
    """A backend with a background acquisition task (sample-and-hold)."""

    def prepare(self, t: float) -> None: ...

    async def run(self) -> None: ...


Factory = Callable[[BackendContext], Hardware]

#: name -> "module:function" of the built-in backends, imported on first use.
_BUILTIN: dict[str, str] = {
    "sim": "sondalog.backends.sim:create",
    "linux": "sondalog.backends.linux:create",
}
_REGISTERED: dict[str, Factory] = {}


class UnknownBackend(LookupError):
    """No backend of that name (or its module cannot be imported)."""


def register(name: str, factory: Factory) -> None:
    """Make ``factory`` the backend called ``name`` (a plug-in's own hardware, a test's)."""
    _REGISTERED[name] = factory


def names() -> list[str]:
    """Every backend name that can be asked for."""
    return sorted({*_BUILTIN, *_REGISTERED})


def factory(name: str) -> Factory:
    """The factory of backend ``name``; raises :class:`UnknownBackend`."""
    if name in _REGISTERED:
        return _REGISTERED[name]
    target = _BUILTIN.get(name)
    if target is None:
        raise UnknownBackend(f"no hardware backend {name!r} (known: {', '.join(names())})")
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownBackend(f"hardware backend {name!r} is not available: {exc}") from exc
    created: Factory = getattr(module, attr)
    _REGISTERED[name] = created
    return created


def create(name: str, context: BackendContext) -> Hardware:
    """Build backend ``name`` for ``context``."""
    return factory(name)(context)
