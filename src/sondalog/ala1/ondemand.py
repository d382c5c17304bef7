"""On-demand measurement (§6.5.8) compiled from the committed configuration (issue 11).

``read channel value`` measures every channel now. For a channel that never has to wait (no
switched input left to the module, §6.5.13; no DS18B20 conversion) and whose value is the
internal ADC through the calibration (:meth:`~sondalog.ala1.measure.Measurer.direct`), the
measurement is one function of the host time, made once per configuration: the same floats in
the same order as :meth:`~sondalog.ala1.state.Transaction.measure`, without interpreting the
configuration on every read. Every other channel takes that long way.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from sondalog.ala1.hardware import DS18B20_CONVERSION, Hardware
from sondalog.ala1.measure import (
    Calibration,
    ChannelConfig,
    Input,
    Measurer,
    Reading,
    channel_config,
    format_value,
)
from sondalog.ala1.model import View
from sondalog.ala1.sampling import FaultLog, Outputs, Sampler
from sondalog.ala1.tokens import period_seconds

#: Channel ``ch`` measured at a host time, formatted (empty: no valid value).
Measure = Callable[[float], str]
#: Several channels measured at the same host time.
MeasureMany = Callable[[float], list[str]]
#: Texts of recent values kept per channel (:meth:`OnDemand.many`).
_TEXTS = 4096
#: Seconds a switched sensor stays on at least after its on-demand measurement instant, so a
#: ``command channel switch hold`` of 000000 still measures before switching off (§6.9).
MEASURE_TIME = 0.001


class OnDemand:
    """The compiled on-demand measurements of one module; :meth:`forget` on every change."""

    def __init__(
        self,
        config: Callable[[int], ChannelConfig],
        measurer: Measurer,
        outputs: Outputs,
        faults: FaultLog,
    ) -> None:
        self._config = config
        self._measurer = measurer
        self._outputs = outputs
        self._faults = faults
        self._one: dict[int, Measure | None] = {}
        self._many: dict[tuple[int, ...], MeasureMany | None] = {}

    def forget(self) -> None:
        """The committed configuration (or the manual outputs) changed."""
        self._one.clear()
        self._many.clear()

    def one(self, ch: int) -> Measure | None:
        """Channel ``ch`` as one function, or None when it must take the long way."""
        if ch in self._one:
            return self._one[ch]
        measure = self._one[ch] = self._compile(ch)
        return measure

    def many(self, channels: tuple[int, ...]) -> MeasureMany | None:
        """Several channels as one function, or None when one of them takes the long way."""
        if channels in self._many:
            return self._many[channels]
        singles = [self.one(ch) for ch in channels]
        many: MeasureMany | None = None
        if all(single is not None for single in singles):
            many = self._group(channels, [m for m in singles if m is not None])
        self._many[channels] = many
        return many

    def _group(self, channels: tuple[int, ...], singles: list[Measure]) -> MeasureMany:
        """The channels' readings and texts in one loop: each channel remembers the texts of
        its recent raw readings (an ADC has 4096 levels). A failure anywhere measures each
        channel alone, so that only the failing one has no value."""
        parts: list[tuple[Reading, Calibration, ChannelConfig, dict[float | None, str]]] = []
        for ch in channels:
            cfg = self._config(ch)
            compiled = self._measurer.parts(cfg)
            assert compiled is not None  # (each single compiled)
            parts.append((*compiled, cfg, {}))

        def many(host_now: float) -> list[str]:
            out = []
            try:
                for read, calibrate, cfg, texts in parts:
                    raw = read(host_now)
                    text = texts.get(raw)
                    if text is None:
                        text = format_value(cfg, None if raw is None else calibrate(raw))
                        if len(texts) >= _TEXTS:
                            texts.clear()
                        texts[raw] = text
                    out.append(text)
            except Exception:
                return [single(host_now) for single in singles]
            return out

        return many

    def _compile(self, ch: int) -> Measure | None:
        cfg = self._config(ch)
        direct = self._measurer.direct(cfg)
        manual, faults = self._outputs.manual, self._faults
        if direct is None or any(
            manual.get(i.switch_output, "NO") == "NO" for i in cfg.used_inputs if i.switch_output
        ):
            return None  # a switched input (§6.5.13) or another kind of channel

        def measure(host_now: float) -> str:
            try:
                value = direct(host_now)
            except Exception as exc:  # defence in depth: no valid value (issue 9)
                faults.report(ch, exc, host_now)
                value = None
            return format_value(cfg, value)

        return measure


class MeasuredModule(Protocol):
    """What :func:`measure_now` needs of the module (:class:`~sondalog.ala1.state.ModuleState`)."""

    @property
    def on_demand(self) -> OnDemand: ...
    @property
    def outputs(self) -> Outputs: ...
    @property
    def conversions(self) -> dict[int, float]: ...
    @property
    def clock_offset(self) -> float: ...
    @property
    def hardware(self) -> Hardware: ...
    @property
    def sampler(self) -> Sampler: ...
    @property
    def measurer(self) -> Measurer: ...
    def channel_config(self, ch: int) -> ChannelConfig: ...
    def module_seconds(self, host_now: float) -> float: ...
    def forget_schedule(self) -> None: ...


class MeasuringLine(View, Protocol):
    """What :func:`measure_now` needs of the command line
    (:class:`~sondalog.ala1.state.Transaction`)."""

    @property
    def state(self) -> MeasuredModule: ...
    @property
    def changes(self) -> dict[str, str | None]: ...
    @property
    def reset_all(self) -> bool: ...
    @property
    def host_now(self) -> float: ...
    @property
    def waits(self) -> list[float]: ...


def measure_now(txn: MeasuringLine, ch: int) -> str:
    """§6.5.8: measure channel ``ch`` now (:meth:`~sondalog.ala1.state.Transaction.measure`);
    a switched or DS18B20 input may need time: the line waits (``txn.waits``) and runs
    again."""
    state = txn.state
    pristine = not txn.changes and not txn.reset_all  # the committed view holds
    if pristine and (quick := state.on_demand.one(ch)) is not None:
        return quick(txn.host_now)
    cfg = state.channel_config(ch) if pristine else channel_config(txn, ch)
    now = state.module_seconds(txn.host_now)
    outputs = state.outputs
    ready_at = now
    switched: list[int] = []
    for inp in cfg.used_inputs:
        output = inp.switch_output
        if output and outputs.manual.get(output, "NO") == "NO":
            on_since = outputs.on_since.get(output) if outputs.is_on(output) else None
            powered_at = (on_since if on_since is not None else now) + inp.switch_advance
            ready_at = max(ready_at, powered_at)
            switched.append(output)
        if inp.device_type == "DS18B20" and cfg.type in (3, 9):
            conversion = state.conversions.setdefault(ch, ready_at + DS18B20_CONVERSION)
            ready_at = max(ready_at, conversion)
    if switched:  # (an input without a switch changes no output: nothing to update)
        hold = period_seconds(txn.get("command channel switch hold")) or 0
        for output in switched:  # §6.9: the hold runs from each measurement, renewed
            until = ready_at + max(hold, MEASURE_TIME)
            outputs.held_until[output] = max(outputs.held_until.get(output, 0.0), until)
        outputs.update(now, state.clock_offset)
        state.forget_schedule()  # a hold may have started
    if ready_at > now:
        txn.waits.append(ready_at - now)
        state.hardware.prepare(ready_at - state.clock_offset)  # acquire by then
        return ""
    state.conversions.pop(ch, None)
    run = state.sampler.runs.get(ch)
    window = now - run.last_t if run and run.last_t is not None else float(cfg.period or 1)
    _detect(txn, cfg.inputs[0], ch)
    try:
        value = state.measurer.value(cfg, txn.host_now, window)
    except Exception as exc:  # defence in depth: no valid value (issue 9)
        state.sampler.faults.report(ch, exc, txn.host_now)
        value = None
    return format_value(cfg, value)


def _detect(txn: MeasuringLine, inp: Input, ch: int) -> None:
    """§6.4.3.1.1: a detection address learns the sensor's ROM code."""
    if inp.device_type != "DS18B20" or inp.address & 0xFF or not inp.address:
        return
    found = txn.state.hardware.ds18b20(inp.device_address, inp.address, txn.host_now)
    if found is not None:
        txn.set(f"channel {ch} address", str(found[0] & ~0xFF))
