"""One served logger as the control API drives it (issue 23): inputs, faults, power, state.

A :class:`ControlledLogger` holds what the API needs of a running logger: its
:class:`~sondalog.io.host.DeviceHost`, its memory (a
:class:`~sondalog.backends.store.ala1_nv.LoggerNvStore`) and, for a fleet's, the
:class:`~sondalog.app.fleet.NamedDevice` its engine sits in. Inputs and input faults act on
the simulated hardware (:class:`~sondalog.backends.sim.logger.SimHardware`); line and power
faults put a :class:`~sondalog.app.faults_line.FaultyLines` in front of the engine.

A **restart** (the API's restart, the end of a power loss or of a brown-out below
:data:`RESET_VOLTS`, a restore) is what a real ALA1 does at power-up: a new engine is built
from the memory, so every acknowledged write and the record are there, the module clock runs
on from its saved offset (battery-backed), everything in RAM (a half-typed line, averaging,
switched outputs) starts afresh. Its lines stay connected.

Every method checks all it needs before it changes anything (:class:`Refusal`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from sondalog.ala1 import Engine
from sondalog.ala1.hardware import pin_of
from sondalog.app.control_actions import FAULTS, Action, Clear, Fault, SetInput, input_kind
from sondalog.app.control_snapshot import Preloaded, StoredState, read_state, write_state
from sondalog.app.faults_line import FaultyLines
from sondalog.app.fleet import NamedDevice
from sondalog.backends.sim.logger import Analog, PulseSource, SimHardware, Thermometer
from sondalog.backends.sim.signals import Signal, constant
from sondalog.backends.store.ala1_nv import LoggerNvStore
from sondalog.io.host import DeviceHost

#: Below this supply voltage the module resets (sondalog decision, docs/decisions.md): a
#: brown-out below it is a power loss for as long as it lasts.
RESET_VOLTS = 5.0
#: A DS18B20's power-on reset value, °C: what it answers when no conversion ran.
POWER_ON_CELSIUS = 85.0
_LINE_FAULTS = ("noise", "cut", "slow")


class Refusal(Exception):
    """A request that cannot be applied: HTTP ``status``, message, the field at fault."""

    def __init__(self, status: int, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.message = message
        self.field = field


@dataclass
class Inputs:
    """A copy of the simulated hardware's inputs (a snapshot's)."""

    supply: Signal | None
    analog: dict[int, Analog]
    pulses: list[PulseSource]
    thermometers: list[Thermometer]
    gsm: dict[str, Signal]

    @classmethod
    def of(cls, hw: SimHardware) -> Inputs:
        return cls(
            hw.supply_signal,
            {pin: replace(a) for pin, a in hw.analog.items()},
            [replace(p) for p in hw.pulse_sources],
            [replace(t) for t in hw.thermometers],
            dict(hw.gsm_signals),
        )

    def put(self, hw: SimHardware) -> None:
        hw.supply_signal = self.supply
        hw.analog = {pin: replace(a) for pin, a in self.analog.items()}
        hw.pulse_sources = [replace(p) for p in self.pulses]
        hw.thermometers = [replace(t) for t in self.thermometers]
        hw.gsm_signals = dict(self.gsm)


@dataclass
class ActiveFault:
    fault: Fault
    until: float | None  # clock time it ends (None: until cleared)
    undo: Any = None  # what clearing puts back


@dataclass
class ControlledLogger:
    name: str
    host: DeviceHost
    store: LoggerNvStore
    named: NamedDevice | None = None
    lines: FaultyLines | None = None
    faults: dict[tuple[str, str | None], ActiveFault] = field(default_factory=dict)
    snapshots: dict[str, tuple[StoredState, Inputs | None]] = field(default_factory=dict)
    off: bool = False
    restarts: int = 0

    # -- what it is ------------------------------------------------------------------------
    @property
    def engine(self) -> Engine:
        if self.named is not None:
            return self.named.engine
        device = self.lines.inner if self.lines is not None else self.host.device
        assert isinstance(device, Engine)
        return device

    @property
    def sim(self) -> SimHardware | None:
        hardware = self.engine.state.hardware
        return hardware if isinstance(hardware, SimHardware) else None

    def hardware(self, what: str) -> SimHardware:
        sim = self.sim
        if sim is None:
            raise Refusal(409, f"{self.name} has real hardware: {what} needs the sim backend")
        return sim

    # -- inputs ------------------------------------------------------------------------------
    def inputs(self, t: float) -> dict[str, object]:
        """Every input's name -> its value now (volts, °C, pulses per second; None: none)."""
        sim = self.sim
        if sim is None:
            return {}
        out: dict[str, object] = {"supply": _value(sim.supply_signal, t)}
        out.update({f"analog:{a.address}": _value(a.signal, t) for a in sim.analog.values()})
        out.update({f"ds18b20:{s.rom:016X}": _value(s.signal, t) for s in sim.thermometers})
        for p in sim.pulse_sources:
            name = "pulses:timer" if p.timer else f"pulses:{p.address}"
            out[name] = p.rate if p.rate or not p.burst_rate else {"poisson": p.burst_rate}
        out.update({f"gsm:{k}": _value(s, t) for k, s in sim.gsm_signals.items()})
        for kind, faulted in self.faults:
            if kind == "disconnected" and faulted is not None:
                out[faulted] = None
        return out

    def check_input(self, name: str, field: str = "input") -> None:
        """Refuse an input this logger does not have."""
        sim = self.hardware("an input")
        if not _has(sim, name) and self.fault_on(name) is None:
            known = ", ".join(self.inputs(0.0)) or "none"
            raise Refusal(404, f"{self.name} has no input {name} (its inputs: {known})", field)

    def channel_input(self, name: str) -> str:
        """The input channel ``chN`` reads first, as configured now (§6.5.5: its type, its
        device's type and address)."""
        n, state = int(name[2:]), self.engine.state
        count = int(state.get("channel max number"))
        if not 1 <= n <= count:
            raise Refusal(404, f"{self.name} has no channel {n} (it has {count})", "input")
        cfg = state.channel_config(n)
        first, kind = cfg.inputs[0], cfg.type
        device = first.device_type if first.device else ""
        found = {
            (11, ""): "gsm:credit",
            (12, ""): "gsm:signal",
            (1, "MSP430ADC"): "supply",
            (3, "MSP430ADC"): f"analog:{first.address}",
            (9, "MSP430ADC"): f"analog:{first.address}",
            (2, "MSP430TA"): "pulses:timer",
            (6, "MSP430TA"): "pulses:timer",
            (2, "MSP430ADC"): f"pulses:{first.address}",
            (6, "MSP430ADC"): f"pulses:{first.address}",
        }.get((kind, "" if kind in (11, 12) else device))
        if kind in (3, 9) and device == "DS18B20":
            found = self._thermometer(first.device_address, first.address)
        if found is None:
            raise Refusal(409, f"channel {n} reads no simulated input: name the input", "input")
        return found

    def _thermometer(self, pin: int, rom: int) -> str | None:
        sim = self.hardware("an input")
        if rom and rom & 0xFF:
            return f"ds18b20:{rom:016X}"
        on_pin = [t for t in sim.thermometers if t.pin == pin]
        return f"ds18b20:{on_pin[0].rom:016X}" if len(on_pin) == 1 else None

    def fault_on(self, name: str) -> str | None:
        return next((kind for (kind, on) in self.faults if on == name), None)

    def set_input(self, action: SetInput, now: float) -> None:
        self.check_input(action.input)
        if (kind := self.fault_on(action.input)) is not None:
            raise Refusal(409, f"{action.input} has a {kind} fault: clear it first", "input")
        sim = self.hardware("an input")
        if action.rate is not None:
            for source in _pulse_sources(sim, action.input):
                source.rate, source.burst_rate, source.origin = action.rate, 0.0, now
            return
        assert action.signal is not None
        sim.set_signal(action.input, action.signal.build(now))

    # -- faults of inputs --------------------------------------------------------------------
    def fault_input(self, fault: Fault, now: float) -> Any:
        """Apply an input's fault; returns what clearing it puts back."""
        name = fault.input
        assert name is not None
        self.check_input(name)
        if (kind := self.fault_on(name)) is not None:
            raise Refusal(409, f"{name} already has a {kind} fault: clear it first", "input")
        sim = self.hardware("a fault of an input")
        what, key = input_kind(name), name.partition(":")[2]
        if fault.kind == "disconnected":
            if what == "analog":
                return sim.analog.pop(pin_of(int(key)))
            if what == "ds18b20":
                sensor = _sensor(sim, key)
                sim.thermometers.remove(sensor)
                return sensor
            if what == "pulses":
                gone = _pulse_sources(sim, name)
                sim.pulse_sources = [p for p in sim.pulse_sources if p not in gone]
                return gone
            if what == "supply":
                old, sim.supply_signal = sim.supply_signal, None
                return old
            return sim.gsm_signals.pop(key, None)
        if fault.kind == "bad_crc":
            _sensor(sim, key).crc_error = True
            return None
        old = _signal_of(sim, name)
        if fault.kind == "stuck":
            sim.set_signal(name, constant(_value(old, now) or 0.0))
        else:  # power_on_reset
            sim.set_signal(name, constant(POWER_ON_CELSIUS))
        return old

    def clear_input(self, active: ActiveFault) -> None:
        sim = self.hardware("a fault of an input")
        fault, undo = active.fault, active.undo
        name = fault.input
        assert name is not None
        what, key = input_kind(name), name.partition(":")[2]
        if fault.kind == "disconnected":
            if what == "analog":
                sim.analog[pin_of(int(key))] = undo
            elif what == "ds18b20":
                sim.thermometers.append(undo)
            elif what == "pulses":
                sim.pulse_sources.extend(undo)
            elif what == "supply":
                sim.supply_signal = undo
            elif undo is not None:
                sim.gsm_signals[key] = undo
        elif fault.kind == "bad_crc":
            _sensor(sim, key).crc_error = False
        elif undo is not None:
            sim.set_signal(name, undo)

    # -- lines and power ---------------------------------------------------------------------
    def wrapped(self) -> FaultyLines:
        """The engine behind its line and power faults (put in front of it if not yet)."""
        if self.lines is None:
            inner = self.named if self.named is not None else self.host.device
            self.lines = FaultyLines(inner, self.host.clock.speed)
            self.host.replace_device(self.lines)
        return self.lines

    def unwrap_if_quiet(self) -> None:
        lines = self.lines
        if lines is not None and lines.quiet:
            self.lines = None
            self.host.replace_device(lines.inner)

    def fault_line(self, fault: Fault) -> None:
        lines = self.wrapped()
        if fault.kind == "noise":
            lines.set_noise(fault.noise)
        elif fault.kind == "cut":
            lines.cut = True
        else:
            lines.slow = fault.slow

    def clear_line(self, kind: str) -> None:
        lines = self.wrapped()
        if kind == "noise":
            lines.set_noise(None)
        elif kind == "cut":
            lines.cut = False
        else:
            lines.slow = None
        self.unwrap_if_quiet()

    def power_off(self) -> None:
        """The supply is gone: everything in RAM with it; the memory keeps what it holds."""
        self.store.database.flush()  # (rows the group commit holds are written at once)
        lines = self.wrapped()
        lines.off = True
        lines.drop_held()
        self.off = True
        sim = self.sim
        if sim is not None:
            sim.outputs.clear()  # every output falls back to off
        self.host.wake()

    def power_on(self, now: float) -> None:
        self.restart(now)
        if self.lines is not None:
            self.lines.off = False
        self.off = False
        self.unwrap_if_quiet()
        self.host.wake()

    def restart(self, now: float, memory: Preloaded | None = None) -> None:
        """A new engine from the memory, on the same lines (see the module docstring);
        ``memory``: the memory just restored, which it starts from without reading it back.
        A com line that drives a GSM modem drives it again: the new engine's modem driver
        starts afresh (the modem itself keeps its state, as a real one across a reset)."""
        self.store.database.flush()
        old = self.engine
        lines = dict(old._lines)  # the attached lines: the engine has no public list of them
        hardware, scale = old.state.hardware, old.scale
        new = Engine(old.identity, memory or self.store, now, hardware, line_time_scale=scale)
        new.state.store = self.store
        top = max(lines, default=0)
        modem = old.modem.line if old.modem is not None else None
        for line_id in range(1, top + 1):  # the same ids, as the host knows them
            if line_id == modem:
                opened = new.attach_modem(now)
            else:
                paced = lines[line_id].pacer.paced if line_id in lines else False
                opened = new.open_line(paced=paced)
            assert opened == line_id
            if line_id not in lines:
                new.close_line(line_id)
        if self.named is not None:
            self.named.engine = new
        elif self.lines is not None:
            self.lines.inner = new
        else:
            self.host.replace_device(new)
        self.restarts += 1
        self.host.wake()

    def jump_clock(self, seconds: float, now: float) -> None:
        """The module clock jumps by ``seconds`` (its battery-backed clock glitched)."""
        state = self.engine.state
        state.clock_offset += seconds
        state.store.commit({}, state.clock_offset, seen=now)
        state.generation += 1
        state.sampler.reschedule(math.floor(state.module_seconds(now)))
        state.forget_schedule()
        self.host.wake()

    # -- snapshot and restore ----------------------------------------------------------------
    def snapshot(self, name: str) -> StoredState:
        state = read_state(self.store, self.engine.state.record)
        sim = self.sim
        self.snapshots[name] = (state, Inputs.of(sim) if sim is not None else None)
        return state

    def check_restorable(self, name: str) -> None:
        if name not in self.snapshots:
            known = ", ".join(self.snapshots) or "none"
            raise Refusal(
                404, f"{self.name} has no snapshot {name!r} (its snapshots: {known})", "name"
            )

    def restore(self, name: str, now: float) -> StoredState:
        self.check_restorable(name)
        state, inputs = self.snapshots[name]
        write_state(self.store, state, self.engine.state.record)
        sim = self.sim
        if inputs is not None and sim is not None:
            inputs.put(sim)
        self.restart(now, Preloaded(self.store, state))
        return state


def resolve_channel(logger: ControlledLogger, action: Action) -> Action:
    """``action`` with a channel's input (``ch2``) replaced by the input it reads, checked
    as the input's name would have been when the request was read."""
    name = getattr(action, "input", None)
    if not isinstance(action, SetInput | Fault | Clear) or not (name or "").startswith("ch"):
        return action
    real = logger.channel_input(str(name))
    kind = input_kind(real)
    if isinstance(action, Fault) and kind not in FAULTS[action.kind]:
        raise Refusal(400, f"{name} reads {real}: a {action.kind} fault needs another", "input")
    if isinstance(action, SetInput) and (action.rate is not None) != (kind == "pulses"):
        raise Refusal(400, f"{name} reads {real}: a counter takes a rate, others a value", "input")
    return replace(action, input=real)


def _value(signal: Signal | None, t: float) -> float | None:
    if signal is None:
        return None
    value = signal(t)
    return value if math.isfinite(value) else None


def _has(sim: SimHardware, name: str) -> bool:
    what, key = input_kind(name), name.partition(":")[2]
    if what in ("supply", "gsm"):
        return True
    if what == "analog":
        return key.isdigit() and pin_of(int(key)) in sim.analog
    if what == "ds18b20":
        return any(t.rom == int(key, 16) for t in sim.thermometers)
    if what == "pulses":
        return bool(_pulse_sources(sim, name))
    return False


def _sensor(sim: SimHardware, key: str) -> Thermometer:
    return next(t for t in sim.thermometers if t.rom == int(key, 16))


def _pulse_sources(sim: SimHardware, name: str) -> list[PulseSource]:
    key = name.partition(":")[2]
    if key == "timer":
        return [p for p in sim.pulse_sources if p.timer]
    return [p for p in sim.pulse_sources if not p.timer and pin_of(p.address) == pin_of(int(key))]


def _signal_of(sim: SimHardware, name: str) -> Signal | None:
    what, key = input_kind(name), name.partition(":")[2]
    if what == "supply":
        return sim.supply_signal
    if what == "analog":
        return sim.analog[pin_of(int(key))].signal
    if what == "ds18b20":
        return _sensor(sim, key).signal
    return sim.gsm_signals.get(key)


def logger_json(name: str, logger: ControlledLogger) -> dict[str, Any]:
    identity = logger.engine.identity
    return {
        "name": name,
        "kind": "logger",
        "serial_number": identity.serial_number,
        "protocol": identity.version.value,
        "simulated": logger.sim is not None,
        "powered": not logger.off,
        "faults": [fault_json(a) for a in logger.faults.values()],
    }


def fault_json(active: ActiveFault) -> dict[str, Any]:
    fault = active.fault
    out: dict[str, Any] = {"kind": fault.kind}
    for key in ("input", "volts", "seconds", "number", "code"):
        value = getattr(fault, key)
        if value is not None:
            out[key] = value
    if fault.noise is not None:
        noise = fault.noise
        out.update(rate=noise.rate, seed=noise.seed, direction=noise.direction, mode=noise.mode)
    if fault.slow is not None:
        out.update(baud=fault.slow.baud, latency=fault.slow.latency)
    if active.until is not None:
        out["until"] = active.until
    return out
