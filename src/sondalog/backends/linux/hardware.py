"""The ALA1 module's inputs and outputs on a Linux board (DESIGN.md point 4; §6.4, §6.7).

:class:`LinuxHardware` answers the core's :class:`~sondalog.ala1.hardware.Hardware` calls at
once from a *sample-and-hold cache*; an acquisition task (:meth:`LinuxHardware.run`) fills it:

- before a sample (:meth:`LinuxHardware.prepare` with its host time ``t``) it starts a bulk
  DS18B20 conversion 750 ms ahead (§7 notes), reads the thermometers, then the IIO channels,
  so the values are fresh at ``t``;
- between samples it reads everything every ``refresh`` seconds (for on-demand reads,
  §6.5.8), and ``settle`` seconds after an output has switched a sensor on (§6.5.13);
- pulse inputs are edge events with kernel timestamps, counted exactly per window.

A reading is valid for ``hold`` seconds; a reading of a switched sensor (``power``) is valid
only while its output is on and only if taken after it was switched on. Blocking sysfs I/O
runs in worker threads; the core's calls never block.
"""

from __future__ import annotations

import asyncio
import contextlib
import heapq
import logging
import select
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from sondalog.ala1.hardware import (
    DS18B20_CONVERSION,
    DS18B20_SCALE,
    INTERNAL_REFERENCE,
    SUPPLY_DIVIDER,
    normalise,
    pin_of,
)
from sondalog.backends.linux.board import BoardConfig, IioWiring, PulseWiring
from sondalog.backends.linux.fakegpio import DirChip
from sondalog.backends.linux.gpio import EdgeLines, GpioChip, GpiodChip, OutputLines, PulseCounter
from sondalog.backends.linux.iio import IioChannel, IioError, find_device
from sondalog.backends.linux.w1 import W1Master, find_masters, rom_from_slave

log = logging.getLogger(__name__)
#: Readings are taken this long before the time the core asked for.
MARGIN = 0.1
#: Longest wait for a bulk conversion to finish (the kernel's own timeout is similar).
BULK_TIMEOUT = 2.0
CONSUMER = "sondalog"
#: How to get the optional GPIO bindings.
INSTALL = "pip install 'sondalog[linux]'"


@dataclass(slots=True)
class _Held:
    value: float | None
    at: float  # host time of the reading


@dataclass(slots=True)
class _Pulse:
    wiring: PulseWiring
    counter: PulseCounter
    offset: int


class LinuxHardware:
    """:class:`~sondalog.ala1.hardware.Hardware` and ``Acquiring`` of one Linux board."""

    def __init__(
        self,
        board: BoardConfig,
        *,
        root: Path = Path("/"),
        chips: Mapping[str, GpioChip] | None = None,
        host_now: Callable[[], float] = time.time,
    ) -> None:
        self.board = board
        self.root = root
        self.host_now = host_now
        self.w1: dict[int, W1Master] = {}
        for wire in board.ds18b20:
            path = root / "sys/bus/w1/devices" / wire.master
            if not path.is_dir():
                known = ", ".join(find_masters(root)) or "none"
                raise board.error(f"{wire.where}.master", f"no 1-Wire master here (found: {known})")
            self.w1[wire.pin] = W1Master(path)
        self.channels: dict[int | None, tuple[IioWiring, IioChannel]] = {}
        for wiring in (*board.analog, *([board.supply] if board.supply else [])):
            try:
                channel = IioChannel(find_device(root, wiring.iio), wiring.channel)
            except IioError as exc:
                raise board.error(f"{wiring.where}.iio", str(exc)) from None
            key = None if wiring.address is None else pin_of(wiring.address)
            self.channels[key] = (wiring, channel)
        self._chips: dict[str, GpioChip] = dict(chips or {})
        self._own_chips: list[GpioChip] = []
        self._outputs: dict[int, tuple[OutputLines, int]] = {}
        self._edges: list[tuple[EdgeLines, PulseCounter]] = []
        self._pulses: list[_Pulse] = []
        try:
            self._request_lines()
        except BaseException:
            self.close()
            raise
        self.levels: dict[int, bool] = {}
        self.on_since: dict[int, float] = {}
        self._temps: dict[int, dict[int, _Held]] = {}  # pin -> ROM -> celsius
        self._seen: dict[int, _Held] = {}  # pin -> when its bus was last listed
        self._volts: dict[int | None, _Held] = {}
        self._requests: list[float] = []
        self._wake: asyncio.Event | None = None
        self._lock: asyncio.Lock | None = None
        self._last_pass = float("-inf")

    # -- set-up ---------------------------------------------------------------------------------
    def _chip(self, name: str, where: str) -> GpioChip:
        chip = self._chips.get(name)
        if chip is None:
            path = name if name.startswith("/") else str(self.root / "dev" / name)
            try:
                if Path(path).is_dir():  # a fake tree's chip (docs/linux-board.md)
                    chip = DirChip(Path(path))
                    log.warning("%s is a directory: GPIO lines are files in it", path)
                else:
                    chip = GpiodChip(path)
            except ImportError:
                raise self.board.error(
                    f"{where}.chip", f"GPIO needs the gpiod bindings (libgpiod v2): {INSTALL}"
                ) from None
            except (OSError, ValueError) as exc:
                raise self.board.error(f"{where}.chip", f"cannot open {path}: {exc}") from None
            self._chips[name] = chip
            self._own_chips.append(chip)
        return chip

    def _offset(self, chip: GpioChip, line: int | str, where: str) -> int:
        try:
            return chip.offset_of(line)
        except (OSError, ValueError) as exc:
            raise self.board.error(f"{where}.line", f"no such line: {exc}") from None

    def _request_lines(self) -> None:
        by_chip: dict[str, dict[int, bool]] = {}
        owners: dict[int, tuple[str, int]] = {}
        for out in self.board.outputs:
            offset = self._offset(self._chip(out.chip, out.where), out.line, out.where)
            by_chip.setdefault(out.chip, {})[offset] = out.active_low
            owners[out.output] = (out.chip, offset)
        requests: dict[str, OutputLines] = {}
        for name, lines in by_chip.items():
            try:
                requests[name] = self._chips[name].request_outputs(lines, CONSUMER)
            except (OSError, ValueError) as exc:
                where = next(o.where for o in self.board.outputs if o.chip == name)
                raise self.board.error(f"{where}.line", f"cannot request: {exc}") from None
        for output, (name, offset) in owners.items():
            self._outputs[output] = (requests[name], offset)
        for wiring in self.board.pulses:
            chip = self._chip(wiring.chip, wiring.where)
            offset = self._offset(chip, wiring.line, wiring.where)
            try:
                edges = chip.request_edges(
                    [offset],
                    CONSUMER,
                    edge=wiring.edge,
                    bias=wiring.bias,
                    debounce=wiring.debounce,
                )
            except (OSError, ValueError) as exc:
                raise self.board.error(f"{wiring.where}.line", f"cannot request: {exc}") from None
            counter = PulseCounter(lambda: self.host_now())
            counter.watch(offset)
            self._edges.append((edges, counter))
            self._pulses.append(_Pulse(wiring, counter, offset))

    def close(self) -> None:
        """Release every GPIO line (outputs go inactive) and close the chips opened here."""
        for edges, _ in self._edges:
            edges.release()
        for lines, offset in self._outputs.values():
            with contextlib.suppress(OSError):
                lines.set(offset, False)  # a relay left on would drain the battery
        for outputs in {id(r): r for r, _ in self._outputs.values()}.values():
            outputs.release()
        for chip in self._own_chips:
            chip.close()
        self._edges, self._outputs, self._own_chips = [], {}, []

    # -- Hardware: the core's synchronous reads ---------------------------------------------------
    def _valid(self, held: _Held | None, power: int | None, t: float) -> float | None:
        if held is None or held.value is None or abs(t - held.at) > self.board.hold:
            return None
        if power is not None:
            since = self.on_since.get(power) if self.levels.get(power) else None
            if since is None or held.at < since + self.board.settle:
                return None  # unpowered, or read before the sensor had settled
        return held.value

    def adc(self, device: int, address: int, t: float) -> float | None:
        found = self.channels.get(pin_of(address))
        if found is None:
            return None
        wiring = found[0]
        volts = self._valid(self._volts.get(pin_of(address)), wiring.power, t)
        if volts is None:
            return None
        reference = self.board.external_reference if address >= 32 else INTERNAL_REFERENCE
        return normalise(volts, reference)

    def supply(self, t: float) -> float | None:
        found = self.channels.get(None)
        if found is None:
            return None
        volts = self._valid(self._volts.get(None), found[0].power, t)
        return None if volts is None else normalise(volts / SUPPLY_DIVIDER)

    def pulses(self, device: int, address: int, timer: bool, t0: float, t1: float) -> int:
        self.poll_edges()
        return sum(
            p.counter.count(p.offset, t0, t1)
            for p in self._pulses
            if p.wiring.timer == timer and (timer or pin_of(p.wiring.address) == pin_of(address))
        )

    def ds18b20(self, pin: int, rom: int, t: float) -> tuple[int, float] | None:
        wire = next((w for w in self.board.ds18b20 if w.pin == pin), None)
        sensors = self._temps.get(pin)
        if wire is None or sensors is None:
            return None
        if self._valid(self._seen.get(pin), wire.power, t) is None:
            return None
        if rom == 0 or rom & 0xFF == 0:
            if len(sensors) != 1:
                return None  # nothing there, or several sensors answering at once
            rom = next(iter(sensors))
        celsius = self._valid(sensors.get(rom), wire.power, t)
        return None if celsius is None else (rom, celsius / DS18B20_SCALE)

    def thermometers(self, pin: int) -> dict[int, float | None]:
        """The sensors the last pass found on P6 bit ``pin``: ROM code -> °C (or None)."""
        return {rom: held.value for rom, held in self._temps.get(pin, {}).items()}

    def gsm(self, what: str, t: float) -> float | None:
        return None  # no modem on this backend (the GSM issue brings one)

    def set_output(self, output: int, on: bool, t: float) -> None:
        if self.levels.get(output, False) != on:
            self.levels[output] = on
            if on:
                self.on_since[output] = t
                self.prepare(t + self.board.settle + self._lead())
        wired = self._outputs.get(output)
        if wired is not None:
            lines, offset = wired
            try:
                lines.set(offset, on)
            except OSError:
                log.exception("output %d: cannot set its GPIO line", output)

    # -- Acquiring ------------------------------------------------------------------------------
    def _lead(self) -> float:
        """How long before ``t`` an acquisition must start to be complete at ``t``."""
        return MARGIN + (DS18B20_CONVERSION if self.w1 else 0.0)

    def prepare(self, t: float) -> None:
        """The core will read the inputs at host time ``t``: have fresh values by then.
        Called from the event loop's thread."""
        heapq.heappush(self._requests, t)
        if self._wake is not None:
            self._wake.set()

    def poll_edges(self) -> None:
        """Take the edge events that are waiting (never blocks)."""
        for lines, counter in self._edges:
            fd = lines.fileno()
            if select.select([fd], [], [], 0)[0]:
                self._on_edges(lines, counter)

    def _on_edges(self, lines: EdgeLines, counter: PulseCounter) -> None:
        try:
            edges = lines.read()
        except OSError:
            log.exception("cannot read edge events")
            return
        counter.take(edges, lines.clock_ns())

    def next_acquisition(self) -> float:
        """Host time the next acquisition pass should start (a prepared read or the
        periodic refresh)."""
        due = self._last_pass + self.board.refresh
        if self._requests:
            due = min(due, self._requests[0] - self._lead())
        return due

    async def run(self) -> None:
        """The acquisition task: runs until cancelled; then the board's GPIO lines are
        released (:meth:`close`: outputs inactive), as the logger stops by cancelling it."""
        loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        for lines, counter in self._edges:
            loop.add_reader(lines.fileno(), self._on_edges, lines, counter)
        try:
            while True:
                wait = self.next_acquisition() - self.host_now()
                if wait > 0:
                    self._wake.clear()
                    # not wait_for: on 3.11 it swallows a cancel that comes with the wake-up
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(wait):
                            await self._wake.wait()
                    continue
                try:
                    await self.acquire()
                except Exception:  # a device loop never stops (DESIGN.md point 6)
                    log.exception("acquisition failed")
                    self._last_pass = self.host_now()
        finally:
            for lines, _ in self._edges:
                loop.remove_reader(lines.fileno())
            self.close()

    async def acquire(self) -> None:
        """One pass: every thermometer (a bulk conversion where the master has one), then
        every IIO channel; the cache holds the results with their host times. Prepared
        reads whose pass is due are served by it."""
        if self._lock is None:
            self._lock = asyncio.Lock()
        async with self._lock:
            now = self.host_now()
            while self._requests and self._requests[0] - self._lead() <= now:
                heapq.heappop(self._requests)
            if self.w1:
                await self._acquire_w1()
            if self.channels:
                volts = await asyncio.to_thread(self._read_channels)
                at = self.host_now()
                for key, value in volts.items():
                    self._volts[key] = _Held(value, at)
            self._last_pass = self.host_now()

    async def _acquire_w1(self) -> None:
        triggered = await asyncio.to_thread(
            lambda: [m.trigger() for m in self.w1.values() if m.has_bulk]
        )
        if any(triggered):
            await asyncio.sleep(DS18B20_CONVERSION)
            waited = DS18B20_CONVERSION
            while waited < BULK_TIMEOUT and await asyncio.to_thread(
                lambda: any(m.converting() for m in self.w1.values())
            ):
                await asyncio.sleep(0.05)
                waited += 0.05
        found = await asyncio.to_thread(self._read_w1)
        at = self.host_now()
        for pin, temps in found.items():
            self._seen[pin] = _Held(1.0, at)
            self._temps[pin] = {
                rom_from_slave(slave): _Held(celsius, at) for slave, celsius in temps.items()
            }

    def _read_w1(self) -> dict[int, dict[str, float | None]]:
        return {pin: {s: m.read(s) for s in m.slaves()} for pin, m in self.w1.items()}

    def _read_channels(self) -> dict[int | None, float | None]:
        out: dict[int | None, float | None] = {}
        for key, (wiring, channel) in self.channels.items():
            volts = channel.volts()
            out[key] = None if volts is None else volts * wiring.gain
        return out
