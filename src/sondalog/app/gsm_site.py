"""A site file's ``[gsm]`` table as ``sondalog serve`` runs it (``docs/gsm.md``).

The world itself (subscribers, SMS centre, USSD, hosts, outages) is checked by
:func:`sondalog.gsm.config.parse`; this module adds what serving needs and checks it the same
way (errors name file, line and field)::

    [gsm]
    logger_modem = "+420600000001"       # the logger's modem: [logger.gsm] models drive it

    [gsm.serve]
    api = "127.0.0.1:8025"               # the HTTP JSON API (loopback only)

    [[gsm.modem]]
    number = "+420600000001"
    signal = { model = "sine", mean = 18, amplitude = 6, period = 3600 }   # or a number
    credit = 250.0                                                         # or a model

    [gsm.modem.serve]                    # the modem's DTE side
    pty = "/tmp/gsm-modem"               # a pty (stable symlink)
    listen = "127.0.0.1:7001"            # TCP, each connection a line of the same modem
    trace = "modem.trace"                # record the line (relative: in STATE/gsm)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from sondalog.backends.sim.signals import Signal, SignalError, build_signal
from sondalog.config import ConfigError, Fail, locate, serve_table
from sondalog.config.address import parse_listen
from sondalog.gsm.config import GsmConfig, GsmConfigError, parse
from sondalog.gsm.sms import normalize

DEFAULT_API = ("127.0.0.1", 8025)
_SERVE = {"api"}
_MODEM_SERVE = {"pty", "listen", "trace"}


@dataclass(frozen=True)
class ModemServe:
    number: str
    pty: Path | None = None
    listen: tuple[str, int] | None = None
    trace: Path | None = None


@dataclass(frozen=True)
class GsmPlan:
    config: GsmConfig
    api: tuple[str, int] = DEFAULT_API
    modems: tuple[ModemServe, ...] = ()
    logger_modem: str | None = None
    signals: dict[str, Signal] = field(default_factory=dict)
    credits: dict[str, Signal] = field(default_factory=dict)


def parse_gsm_site(
    data: Mapping[str, object], path: Path, text: str, start: float = 0.0
) -> GsmPlan:
    """Check ``data["gsm"]``; raises :class:`ConfigError`. Signal models start at ``start``."""

    def fail(where: str, message: str) -> ConfigError:
        return ConfigError(path, where, message, locate(text, where))

    table = data.get("gsm")
    if not isinstance(table, Mapping):
        raise fail("gsm", "must be a table")
    core: dict[str, Any] = {k: v for k, v in table.items() if k not in ("serve", "logger_modem")}
    serve = serve_table(table, "gsm", _SERVE, fail)
    api = listen_address(serve["api"], "gsm.serve.api", fail) if "api" in serve else DEFAULT_API

    def model(value: object, where: str) -> Signal:
        assert isinstance(value, Mapping)
        try:
            return build_signal(value, start, path.parent)
        except SignalError as exc:
            raise fail(f"{where}.{exc.field}", exc.message) from None

    raw_modems = core.get("modem", [])
    modems: list[ModemServe] = []
    signals: dict[str, Signal] = {}
    credits: dict[str, Signal] = {}
    if isinstance(raw_modems, list):
        stripped = []
        for i, entry in enumerate(raw_modems):
            if not isinstance(entry, Mapping):
                stripped.append(entry)
                continue
            where = f"gsm.modem[{i}]"
            entry = dict(entry)
            number = normalize(str(entry.get("number", "")))
            for key, models in (("signal", signals), ("credit", credits)):
                if isinstance(entry.get(key), Mapping):
                    models[number] = model(entry[key], f"{where}.{key}")
                    entry[key] = round(models[number](start)) if key == "signal" else 0.0
            modems.append(_modem_serve(number, entry, where, fail))
            entry.pop("serve", None)
            stripped.append(entry)
        core["modem"] = stripped
    try:
        config = parse(core)
    except GsmConfigError as exc:
        raise fail(exc.field, str(exc).split(": ", 1)[-1]) from None
    numbers = {m.number for m in config.modems}
    logger_modem = None
    if "logger_modem" in table:
        value = table["logger_modem"]
        logger_modem = normalize(value) if isinstance(value, str) else None
        if logger_modem not in numbers:
            raise fail("gsm.logger_modem", f"{value!r} is not the number of a [[gsm.modem]]")
        _logger_models(data, logger_modem, signals, credits, model)
    return GsmPlan(config, api, tuple(modems), logger_modem, signals, credits)


def _logger_models(
    data: Mapping[str, object],
    number: str,
    signals: dict[str, Signal],
    credits: dict[str, Signal],
    model: Callable[[object, str], Signal],
) -> None:
    """``[logger.gsm]`` ``signal`` and ``credit`` drive the logger's modem (unless the modem
    has its own model)."""
    logger = data.get("logger")
    gsm = logger.get("gsm") if isinstance(logger, Mapping) else None
    if not isinstance(gsm, Mapping):
        return
    if isinstance(gsm.get("signal"), Mapping) and number not in signals:
        signals[number] = model(gsm["signal"], "logger.gsm.signal")
    if isinstance(gsm.get("credit"), Mapping) and number not in credits:
        credits[number] = model(gsm["credit"], "logger.gsm.credit")


def _modem_serve(number: str, entry: Mapping[str, object], where: str, fail: Fail) -> ModemServe:
    """How a ``[[gsm.modem]]`` entry is served (its ``serve`` table)."""
    serve = serve_table(entry, where, _MODEM_SERVE, fail)

    def a_path(key: str) -> Path | None:
        value = serve.get(key)
        if value is None:
            return None
        if not isinstance(value, str) or not value:
            raise fail(f"{where}.serve.{key}", "must be a path in quotes")
        return Path(value)

    listen = (
        listen_address(serve["listen"], f"{where}.serve.listen", fail)
        if "listen" in serve
        else None
    )
    return ModemServe(number, a_path("pty"), listen, a_path("trace"))


def listen_address(value: object, where: str, fail: Fail) -> tuple[str, int]:
    """A ``listen = "HOST:PORT"`` field of a ``serve`` table (``site.py`` uses it too)."""
    if not isinstance(value, str):
        raise fail(where, 'must be "HOST:PORT"')
    try:
        return parse_listen(value)
    except ValueError as exc:
        raise fail(where, str(exc)) from None


def traced(plan: GsmPlan, trace: Path) -> GsmPlan:
    """``plan`` with the line of the logger's modem (else the first modem) traced to
    ``trace`` (``sondalog serve --trace FILE``)."""
    numbers = [m.number for m in plan.config.modems]
    if not numbers:
        return plan
    number = plan.logger_modem or numbers[0]
    modems = [m for m in plan.modems if m.number != number]
    serve = next((m for m in plan.modems if m.number == number), ModemServe(number))
    modems.append(replace(serve, trace=trace.absolute()))
    return replace(plan, modems=tuple(modems))
