"""Hardware backends registered by name (python-can's interface pattern; DESIGN.md point 4).

A backend turns a site file into the :class:`~sondalog.ala1.hardware.Hardware` of a logger.
``sim`` (simulated hardware from the site file's ``[logger]`` table) is built in; ``linux``
(1-Wire, IIO, GPIO on a real board) registers itself the same way. A backend module exposes
``create(context) -> Hardware`` and may expose ``plan(logger: Table) -> object``: its config
parsing, run when the site file is loaded (``serve --check`` too), whose result start hands
back in ``context.plan``; without one, ``create`` reads ``context.site`` itself and
``[logger]`` may hold only ``backend`` and ``serve``. A module is imported only when chosen,
so a missing optional dependency of one backend never stops another.

A backend that drives one real board cannot serve a fleet of loggers (``[[loggers]]``):
its entry says so (``many=False``) and a fleet naming it is refused when the file is loaded.

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
from sondalog.config import Table


@dataclass(frozen=True)
class BackendContext:
    """What a backend is built from: the parsed site file and where it came from."""

    site: Mapping[str, object] = field(default_factory=dict)
    path: Path | None = None
    text: str | None = None
    start: float = 0.0  # host-clock time the backend starts at
    root: Path = Path("/")  # file-system root of sysfs and /dev (tests use a temp dir)
    speed: float = 1.0  # the clock's --speed (a real board's backend refuses anything but 1)
    plan: object = None  # what the backend's ``plan`` made of ``[logger]`` at load, if any


@runtime_checkable
class Acquiring(Protocol):
    """A backend with a background acquisition task (sample-and-hold)."""

    def prepare(self, t: float) -> None: ...

    async def run(self) -> None: ...


Factory = Callable[[BackendContext], Hardware]
#: A backend's config parsing: the ``[logger]`` table -> its checked plan.
Planner = Callable[[Table], object]


@dataclass(frozen=True)
class Backend:
    """A registry entry: the factory, the config parsing, whether a fleet may use it."""

    create: Factory
    plan: Planner | None = None
    many: bool = True  # one process may build it for many loggers (a fleet)


#: name -> (module, serves many loggers) of the built-in backends, imported on first use.
_BUILTIN: dict[str, tuple[str, bool]] = {
    "sim": ("sondalog.backends.sim", True),
    "linux": ("sondalog.backends.linux", False),  # one board, its GPIO lines requested once
}
_REGISTERED: dict[str, Backend] = {}


class UnknownBackend(LookupError):
    """No backend of that name (or its module cannot be imported)."""


def register(
    name: str, factory: Factory, *, plan: Planner | None = None, many: bool = True
) -> None:
    """Make ``factory`` the backend called ``name`` (a plug-in's own hardware, a test's);
    ``plan`` parses its ``[logger]`` table at load, ``many=False`` keeps it out of fleets."""
    _REGISTERED[name] = Backend(factory, plan, many)


def names() -> list[str]:
    """Every backend name that can be asked for."""
    return sorted({*_BUILTIN, *_REGISTERED})


def backend(name: str) -> Backend:
    """The registry entry of backend ``name``; raises :class:`UnknownBackend`."""
    if name in _REGISTERED:
        return _REGISTERED[name]
    if name not in _BUILTIN:
        raise UnknownBackend(f"no hardware backend {name!r} (known: {', '.join(names())})")
    module_name, many = _BUILTIN[name]
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownBackend(f"hardware backend {name!r} is not available: {exc}") from exc
    entry = Backend(module.create, getattr(module, "plan", None), many)
    _REGISTERED[name] = entry
    return entry


def factory(name: str) -> Factory:
    """The factory of backend ``name``; raises :class:`UnknownBackend`."""
    return backend(name).create


def create(name: str, context: BackendContext) -> Hardware:
    """Build backend ``name`` for ``context``."""
    return backend(name).create(context)
