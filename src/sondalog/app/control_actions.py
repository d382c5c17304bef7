"""The control vocabulary (issue 23): what may be done to a served site, as typed values.

One action is one change of the world or of time: **set** an input, inject a **fault**,
**clear** faults, **restart** a logger, **snapshot** and **restore** a logger's whole state,
and the **time** actions (pause, resume, speed, step). The HTTP control API
(:mod:`sondalog.app.control_api`) reads its request bodies into these values, and so will
the site file's ``[[scenario]]`` entries: both read a table through
:class:`sondalog.config.Table` with :func:`parse_action`, which checks every field (a
:class:`~sondalog.config.ConfigError` names it) before anything is applied. Applying them to
a running site is :mod:`sondalog.app.control`'s business; this module only describes.

Inputs are named as the simulated hardware names them (docs/control.md): ``supply``,
``analog:16`` (an A/D input address, §6.5.5), ``ds18b20:28FF...`` (a sensor's ROM code,
§6.4.3.1.1), ``pulses:timer`` or ``pulses:17`` (a counter input), ``gsm:signal`` and
``gsm:credit`` (channel types 12 and 11); on the bus, ``module:T1`` (an HCTMPS1 module by ID).
``ch2`` names the input a logger's channel 2 reads now (its configuration, §6.5).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from sondalog.backends.sim.signals import SignalPlan, constant, plan_signal
from sondalog.config import Table

#: An input of a simulated logger (see the module docstring).
INPUT_PATTERN = (
    r"supply|analog:\d{1,2}|ds18b20:[0-9A-Fa-f]{16}|pulses:(timer|\d{1,2})|gsm:(signal|credit)"
    r"|module:[A-Za-z0-9_-]{1,8}|ch\d{1,2}"
)
_INPUT_WHAT = (
    "an input such as supply, analog:16, ds18b20:<ROM hex>, pulses:timer, gsm:signal, module:T1"
)
#: A snapshot's name.
NAME_PATTERN = r"[A-Za-z0-9_.-]{1,64}"
#: The longest a fault may last, and the largest step or clock jump, in seconds (100 years).
MAX_SECONDS = 100 * 366 * 86400.0
_DURATION = re.compile(r"(?:(\d+(?:\.\d+)?)d)?(?:(\d+(?:\.\d+)?)h)?(?:(\d+(?:\.\d+)?)m)?"
                       r"(?:(\d+(?:\.\d+)?)s)?")  # fmt: skip
#: The fastest a clock may be told to run.
MAX_SPEED = 1e7

#: Fault kinds -> what they act on: an input's kind (analog, ds18b20, pulses, supply, gsm),
#: ``logger`` (the module and its lines), ``gsm`` (the network), ``mail`` (the mail hub).
FAULTS: dict[str, tuple[str, ...]] = {
    "disconnected": ("analog", "ds18b20", "pulses", "supply", "gsm", "module", "ch"),
    "stuck": ("analog", "ds18b20", "supply", "gsm", "module", "ch"),
    "power_on_reset": ("ds18b20", "ch"),  # it answers 85 °C, its power-on value
    "bad_crc": ("ds18b20", "ch"),
    "power_loss": ("logger",),
    "brownout": ("logger",),
    "clock_jump": ("logger",),
    "noise": ("logger",),
    "cut": ("logger",),
    "slow": ("logger",),
    "no_coverage": ("gsm",),
    "smtp_refusing": ("mail",),
}
#: Faults of one input (they need ``input``).
INPUT_FAULTS = ("disconnected", "stuck", "power_on_reset", "bad_crc")
#: A fault that happens once rather than lasting (nothing to clear).
MOMENTARY = ("clock_jump",)


@dataclass(frozen=True, slots=True)
class SetInput:
    """Give an input a new signal (a value is a constant one) or a counter a pulse rate."""

    device: str
    input: str
    signal: SignalPlan | None = None
    rate: float | None = None  # pulses per second of a pulses:... input


@dataclass(frozen=True, slots=True)
class Noise:
    """Errors on a line: each byte, with probability ``rate``, has a bit flipped, is dropped
    or is sent twice (``mode``: flip, drop, duplicate, or mixed: one of them at random)."""

    rate: float
    seed: int = 0
    direction: str = "out"  # out: what the logger sends; in: what it receives; both
    mode: str = "mixed"


@dataclass(frozen=True, slots=True)
class Slow:
    """A slow line: the logger's answers leave at ``baud`` (10 bits a byte) after
    ``latency`` seconds."""

    baud: int
    latency: float = 0.0


@dataclass(frozen=True, slots=True)
class Fault:
    """Fault ``kind`` on ``device`` (on its ``input`` for an input's fault), lasting
    ``duration`` seconds of the site's clock (None: until cleared)."""

    device: str
    kind: str
    input: str | None = None
    duration: float | None = None
    volts: float | None = None  # brownout: the supply's voltage meanwhile
    seconds: float | None = None  # clock_jump: how far the module clock jumps (+/-)
    noise: Noise | None = None
    slow: Slow | None = None
    number: str | None = None  # no_coverage: one subscriber (None: the whole network)
    code: int | None = None  # smtp_refusing: the reply code (4xx: try later, 5xx: never)


@dataclass(frozen=True, slots=True)
class Clear:
    """End faults of ``device``: every one, those of one ``kind`` and/or one ``input``."""

    device: str
    kind: str | None = None
    input: str | None = None


@dataclass(frozen=True, slots=True)
class Restart:
    """The logger restarts from its saved state (a reset: its RAM is lost)."""

    device: str


@dataclass(frozen=True, slots=True)
class Snapshot:
    """Keep the logger's whole state (memory, record, files, inputs) as ``name``."""

    device: str
    name: str


@dataclass(frozen=True, slots=True)
class Restore:
    """Put back the state kept as ``name``: the logger restarts with it."""

    device: str
    name: str


@dataclass(frozen=True, slots=True)
class Pause:
    """Stop the site's clock (devices keep answering; nothing is sampled)."""


@dataclass(frozen=True, slots=True)
class Resume:
    """Let the site's clock run again."""


@dataclass(frozen=True, slots=True)
class Speed:
    """Run the site's clock ``factor`` times real time."""

    factor: float


@dataclass(frozen=True, slots=True)
class Step:
    """Move the site's clock ``seconds`` forward at once, running all that falls due."""

    seconds: float


Action = SetInput | Fault | Clear | Restart | Snapshot | Restore | Pause | Resume | Speed | Step
#: The action names a table may give (``action = "..."`` of a scenario; the API's paths).
ACTIONS = (
    "set",
    "fault",
    "clear",
    "restart",
    "snapshot",
    "restore",
    "pause",
    "resume",
    "speed",
    "step",
)


def input_kind(name: str) -> str:
    """``analog`` of ``analog:16``, ``supply`` of ``supply``, ``ch`` of ``ch2``."""
    kind = name.partition(":")[0]
    return "ch" if re.fullmatch(r"ch\d{1,2}", kind) else kind


def parse_action(
    action: str, device: str, table: Table, extra: tuple[str, ...] = (), *, remote: bool = False
) -> Action:
    """Read ``table`` as action ``action`` on ``device``; ``extra``: keys the caller reads
    itself (a scenario's ``at``); ``remote``: a request over the API (:func:`parse_set`).
    Raises :class:`~sondalog.config.ConfigError`."""
    if action == "set":
        return parse_set(device, table, extra, remote=remote)
    if action == "fault":
        return parse_fault(device, table, extra)
    if action == "clear":
        table.keys(("kind", "input", *extra))
        kind = table.opt_text("kind", choices=FAULTS)
        return Clear(device, kind, _opt_input(table))
    if action in ("restart",):
        table.keys(extra)
        return Restart(device)
    if action in ("snapshot", "restore"):
        table.keys(("name", *extra))
        name = table.text(
            "name", "default", pattern=NAME_PATTERN, what="a name of 1-64 letters, digits, . _ -"
        )
        return Snapshot(device, name) if action == "snapshot" else Restore(device, name)
    return parse_time(action, table, extra)


def parse_time(action: str, table: Table, extra: tuple[str, ...] = ()) -> Action:
    """A time action: pause, resume, speed (``factor``), step (``seconds``)."""
    if action == "speed":
        table.keys(("factor", *extra))
        return Speed(
            table.number("factor", above=0, hi=MAX_SPEED, what=f"a number > 0 and <= {MAX_SPEED:g}")
        )
    if action == "step":
        table.keys(("seconds", *extra))
        return Step(
            table.number("seconds", lo=0, hi=MAX_SECONDS, what=f"seconds, 0 to {MAX_SECONDS:g}")
        )
    table.keys(extra)
    if action == "pause":
        return Pause()
    if action == "resume":
        return Resume()
    raise table.fail("action", f"must be one of {', '.join(ACTIONS)}, not {action!r}")


def parse_set(
    device: str, table: Table, extra: tuple[str, ...] = (), *, remote: bool = False
) -> SetInput:
    """``input`` and one of ``value`` (a constant), ``signal`` (a signal model's table,
    docs/simulation.md) or, for a counter, ``rate`` (pulses per second). ``remote`` (a
    request over the API): no ``csv`` model (it reads a file of the server) and no random
    walk stepping faster than once a second (it keeps every step)."""
    table.keys(("input", "value", "signal", "rate", *extra))
    name = _input(table)
    given = [k for k in ("value", "signal", "rate") if k in table]
    if len(given) != 1:
        raise table.fail("value", "give exactly one of value, signal or rate")
    if input_kind(name) == "pulses":
        if given != ["rate"]:
            raise table.fail(given[0], "a counter input takes rate = pulses per second")
        return SetInput(
            device,
            name,
            rate=table.number("rate", lo=0, hi=1e6, what="pulses per second, 0 to 1e6"),
        )
    if given == ["rate"] and input_kind(name) != "ch":  # (a channel's: once it is resolved)
        raise table.fail("rate", "only a counter input (pulses:...) takes a rate")
    if given == ["rate"]:
        return SetInput(device, name, rate=table.number("rate", lo=0, hi=1e6))
    if given == ["value"]:
        value = table.number("value", lo=-1e9, hi=1e9)
        return SetInput(device, name, SignalPlan("constant", None, lambda origin: constant(value)))
    signal = table.table("signal", required=True)
    if remote and signal.raw("model") == "csv":
        raise signal.fail("model", "a csv signal reads a file of the server: not over the API")
    if remote and signal.raw("model") == "random_walk":  # it keeps a value per interval
        signal.number("interval", 60.0, lo=1, what="seconds >= 1 (over the API)")
    return SetInput(device, name, plan_signal(signal))


def parse_fault(device: str, table: Table, extra: tuple[str, ...] = ()) -> Fault:
    """``kind``, its ``input`` if it is an input's, ``duration`` and the kind's own keys."""
    own = (
        "volts",
        "seconds",
        "rate",
        "seed",
        "direction",
        "mode",
        "baud",
        "latency",
        "number",
        "code",
    )
    table.keys(("kind", "input", "duration", *own, *extra))
    kind = table.text("kind", choices=FAULTS)
    wanted = _FAULT_KEYS.get(kind, ())
    for key in own:
        if key in table and key not in wanted:
            raise table.fail(key, f"is not a setting of a {kind} fault")
    name = None
    if kind in INPUT_FAULTS:
        name = _input(table)
        if input_kind(name) not in FAULTS[kind]:
            raise table.fail("input", f"a {kind} fault needs a {' or '.join(FAULTS[kind])} input")
    elif "input" in table:
        raise table.fail("input", f"a {kind} fault is not an input's")
    if kind in MOMENTARY and "duration" in table:
        raise table.fail("duration", f"a {kind} happens once: it has no duration")
    duration = (
        table.convert("duration", parse_duration)
        if table.is_text("duration")
        else table.opt_number(
            "duration", above=0, hi=MAX_SECONDS, what=f"seconds > 0 and <= {MAX_SECONDS:g}"
        )
    )
    if duration == 0:
        raise table.fail("duration", "must be longer than 0 seconds")
    fault = Fault(device, kind, name, duration)
    if kind == "brownout":
        return replace(fault, volts=table.number("volts", lo=0, hi=40, what="volts, 0 to 40"))
    if kind == "clock_jump":
        seconds = table.number("seconds", lo=-MAX_SECONDS, hi=MAX_SECONDS, what="seconds (+/-)")
        if seconds == 0:
            raise table.fail("seconds", "a jump of 0 seconds changes nothing")
        return replace(fault, seconds=seconds)
    if kind == "noise":
        return replace(fault, noise=Noise(
            table.number("rate", above=0, hi=1, what="a probability per byte, > 0 and <= 1"),
            table.integer("seed", 0, lo=0, hi=2**63),
            table.text("direction", "out", choices=("out", "in", "both")),
            table.text("mode", "mixed", choices=("mixed", "flip", "drop", "duplicate")),
        ))  # fmt: skip
    if kind == "slow":
        return replace(fault, slow=Slow(
            table.integer("baud", lo=10, hi=230400, what="a rate of 10 to 230400 baud"),
            table.number("latency", 0.0, lo=0, hi=3600, what="seconds, 0 to 3600"),
        ))  # fmt: skip
    if kind == "no_coverage":
        number = table.opt_text(
            "number", pattern=r"\+?\d{3,20}", what="a phone number like +420700000001"
        )
        return replace(fault, number=number)
    if kind == "smtp_refusing":
        code = table.integer("code", 451, lo=400, hi=599, what="an SMTP reply code 400 to 599")
        return replace(fault, code=code)
    return fault


_FAULT_KEYS: dict[str, tuple[str, ...]] = {
    "brownout": ("volts",),
    "clock_jump": ("seconds",),
    "noise": ("rate", "seed", "direction", "mode"),
    "slow": ("baud", "latency"),
    "no_coverage": ("number",),
    "smtp_refusing": ("code",),
}


def _input(table: Table) -> str:
    """The input's name, a ROM code in capitals (``ds18b20:28FF...``)."""
    kind, colon, key = table.text("input", pattern=INPUT_PATTERN, what=_INPUT_WHAT).partition(":")
    return kind + colon + key.upper() if kind == "ds18b20" else kind + colon + key


def _opt_input(table: Table) -> str | None:
    return _input(table) if "input" in table else None


def is_input(name: str) -> bool:
    """Whether ``name`` is an input's name (:data:`INPUT_PATTERN`)."""
    return re.fullmatch(INPUT_PATTERN, name) is not None


def parse_duration(text: str) -> float:
    """``90``, ``90s``, ``15m``, ``2h30m``, ``1d``: seconds (0 to 100 years)."""
    value = text.strip()
    match = _DURATION.fullmatch(value)
    if re.fullmatch(r"\d+(\.\d+)?", value):
        seconds = float(value)
    elif value and match is not None:
        d, h, m, s = (float(g) if g else 0.0 for g in match.groups())
        seconds = 86400 * d + 3600 * h + 60 * m + s
    else:
        raise ValueError(f"must be a duration like 90s, 15m, 2h30m or 1d, not {text!r}")
    if seconds > MAX_SECONDS:
        raise ValueError(f"must be at most {MAX_SECONDS:g} seconds")
    return seconds
