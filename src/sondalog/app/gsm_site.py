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

from dataclasses import dataclass, field, replace
from pathlib import Path

from sondalog.backends.sim.signals import Signal, SignalPlan, plan_signal
from sondalog.config import Table, format_address
from sondalog.gsm.config import GsmConfig, entries, parse, phone_number

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
    #: The models of the modems' signal and credit as checked at load ...
    signal_plans: dict[str, SignalPlan] = field(default_factory=dict)
    credit_plans: dict[str, SignalPlan] = field(default_factory=dict)
    #: ... and made for the start time given to :func:`parse_gsm_site` or :meth:`at`.
    signals: dict[str, Signal] = field(default_factory=dict)
    credits: dict[str, Signal] = field(default_factory=dict)

    def at(self, start: float) -> GsmPlan:
        """This plan with its models starting at ``start`` (what serving calls at its start;
        the network applies the models' values at once, so the modems' values at load do not
        matter)."""
        return replace(
            self,
            signals={n: p.build(start) for n, p in self.signal_plans.items()},
            credits={n: p.build(start) for n, p in self.credit_plans.items()},
        )


def parse_gsm_site(site: Table, start: float = 0.0) -> GsmPlan:
    """Check the ``[gsm]`` table of the site file ``site`` (its root table); raises
    :class:`~sondalog.config.ConfigError` naming file, line and field. Signal models start
    at ``start``."""
    gsm = site.table("gsm", required=True)
    api = gsm.table("serve", _SERVE).address("api", format_address(*DEFAULT_API))
    signals: dict[str, SignalPlan] = {}
    credits: dict[str, SignalPlan] = {}

    def model(modem: Table, key: str, number: str) -> float:
        plan = plan_signal(modem.table(key))
        (signals if key == "signal" else credits)[number] = plan
        return plan.build(start)(start) if key == "signal" else 0.0

    config = parse(gsm, keys={"serve", "logger_modem"}, modem_keys={"serve"}, model=model)
    modems = tuple(
        _modem_serve(spec.number, entry.table("serve", _MODEM_SERVE))
        for spec, entry in zip(config.modems, entries(gsm, "modem"), strict=True)
    )
    logger_modem = None
    if "logger_modem" in gsm:
        logger_modem = phone_number(gsm, "logger_modem")
        if logger_modem not in {m.number for m in config.modems}:
            raise gsm.fail("logger_modem", f"{logger_modem} is not the number of a [[gsm.modem]]")
        _logger_models(site, logger_modem, signals, credits)
    return GsmPlan(config, api, modems, logger_modem, signals, credits).at(start)


def _logger_models(
    site: Table, number: str, signals: dict[str, SignalPlan], credits: dict[str, SignalPlan]
) -> None:
    """``[logger.gsm]`` ``signal`` and ``credit`` drive the logger's modem (unless the modem
    has its own model); the rest of ``[logger]`` is the logger's to check."""
    logger = site.table("logger")
    if not logger.is_table("gsm"):
        return
    gsm = logger.table("gsm")
    for key, models in (("signal", signals), ("credit", credits)):
        if gsm.is_table(key) and number not in models:
            models[number] = plan_signal(gsm.table(key))


def _modem_serve(number: str, serve: Table) -> ModemServe:
    """How a ``[[gsm.modem]]`` entry is served (its ``serve`` table)."""

    def a_path(key: str) -> Path | None:
        value = serve.opt_text(key, what="a path in quotes")
        return Path(value) if value is not None else None

    listen = serve.address("listen") if "listen" in serve else None
    return ModemServe(number, a_path("pty"), listen, a_path("trace"))


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
