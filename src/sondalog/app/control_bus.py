"""The RS-485 bus as the control API drives it (issue 23): its HCTMPS1 modules' inputs and
faults (docs/control.md).

A module is named ``module:ID`` (the ID it answers to now, hctmps1 §2) on device ``bus``:
``set`` gives its sensor a new signal (a value is a constant one); the fault
``disconnected`` takes the module off the bus (it hears nothing and answers nothing, as a
module whose cable is cut; it keeps its EEPROM and RAM) and ``stuck`` holds its sensor at
the value it reads now. Clearing puts the module back on the bus and its sensor back.
The module core's sensor is its private ``_sensor`` (a callable of the time): the core has
no setter for it, and the simulation's sensor is the world's, not the module's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from sondalog.app.control_actions import Clear, Fault, SetInput
from sondalog.app.control_logger import ActiveFault, Refusal, fault_json
from sondalog.backends.sim.signals import constant
from sondalog.hctmps1.module import Hctmps1Module
from sondalog.world.bus import BusCore

#: The faults a bus module takes.
BUS_FAULTS = ("disconnected", "stuck")


@dataclass
class ControlledBus:
    core: BusCore
    faults: dict[tuple[str, str | None], ActiveFault] = field(default_factory=dict)
    _off: dict[str, Any] = field(default_factory=dict)  # modules taken off the bus (attached)

    def modules(self) -> dict[str, Hctmps1Module]:
        on = {a.module.module_id: a.module for a in self.core.modules}
        return {**on, **{name: a.module for name, a in self._off.items()}}

    def inputs(self, t: float) -> dict[str, object]:
        """``module:ID`` -> the value it measures now (None: off the bus)."""
        out: dict[str, object] = {}
        for name, module in self.modules().items():
            value: object = None if name in self._off else _float(module.value)
            out[f"module:{name}"] = value
        return out

    def module(self, name: str, field_name: str = "input") -> Hctmps1Module:
        kind, _, key = name.partition(":")
        found = self.modules().get(key) if kind == "module" else None
        if found is None:
            known = ", ".join(self.inputs(0.0)) or "none"
            raise Refusal(404, f"the bus has no input {name} (its inputs: {known})", field_name)
        return found

    def json(self) -> dict[str, Any]:
        return {
            "name": "bus",
            "kind": "bus",
            "faults": [fault_json(a) for a in self.faults.values()],
        }

    def describe(self, now: float) -> dict[str, Any]:
        return {**self.json(), "inputs": self.inputs(now)}

    def set(self, action: SetInput, now: float) -> dict[str, Any]:
        module = self.module(action.input)
        if (kind := self._fault_on(action.input)) is not None:
            raise Refusal(409, f"{action.input} has a {kind} fault: clear it first", "input")
        if action.signal is None:
            raise Refusal(400, "a bus module's input takes a value or a signal", "rate")
        module._sensor = action.signal.build(now)
        return {"device": "bus", "input": action.input, "value": _float(module.value)}

    def fault(self, fault: Fault, now: float) -> dict[str, Any]:
        if fault.kind not in BUS_FAULTS or fault.input is None:
            kinds = " and ".join(f"{k} (of a module:ID input)" for k in BUS_FAULTS)
            raise Refusal(400, f"the bus has no {fault.kind} fault (it has {kinds})", "kind")
        module = self.module(fault.input)
        if (kind := self._fault_on(fault.input)) is not None:
            raise Refusal(409, f"{fault.input} already has a {kind} fault: clear it first", "input")
        active = ActiveFault(fault, None if fault.duration is None else now + fault.duration)
        if fault.kind == "disconnected":
            attached = next(a for a in self.core.modules if a.module is module)
            self.core.modules.remove(attached)
            self._off[module.module_id] = attached
        else:
            active.undo = module._sensor
            module._sensor = constant(_float(module.value) or 0.0)
        self.faults[(fault.kind, fault.input)] = active
        return {"device": "bus", "fault": fault_json(active)}

    def clear(self, clear: Clear) -> list[dict[str, Any]]:
        if clear.input is not None:
            self.module(clear.input)
        keys = [
            key
            for key in self.faults
            if clear.kind in (None, key[0]) and clear.input in (None, key[1])
        ]
        cleared = [fault_json(self.faults[key]) for key in keys]
        for key in keys:
            self.end(key)
        return cleared

    def end(self, key: tuple[str, str | None]) -> None:
        active = self.faults.pop(key)
        name = (active.fault.input or "").partition(":")[2]
        if active.fault.kind == "disconnected":
            attached = self._off.pop(name)
            attached.deadline = attached.module.next_deadline()
            self.core.modules.append(attached)
        else:
            self.modules()[name]._sensor = active.undo

    def _fault_on(self, name: str) -> str | None:
        return next((kind for (kind, on) in self.faults if on == name), None)


def _float(value: str) -> float | None:
    try:
        return float(value)
    except ValueError:
        return None
