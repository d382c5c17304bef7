"""Module state and the per-line transaction (spec notes §3: whole-line atomicity).

:class:`ModuleState` holds what the module remembers: parameters written (non-volatile, in an
:class:`NvStore`), the clock offset (a battery-backed clock), the record memory, the table
files, and in RAM the four line counters of §8.5.7, the sampling state and the outputs. A
command line runs against a :class:`Transaction`: reads see the line's own earlier writes;
nothing reaches the store unless the whole line succeeds, and then it is committed in one
store transaction before the answer is released.
"""

from __future__ import annotations

import logging
import math
from datetime import datetime
from typing import cast

from sondalog.ala1.hardware import Hardware, NoHardware
from sondalog.ala1.measure import ChannelConfig, Measurer, channel_config, format_value
from sondalog.ala1.model import CommandError, Identity
from sondalog.ala1.moduleclock import (
    CLOCK_MAX,
    CLOCK_MIN,
    FACTORY_DATE,
    from_seconds,
    stamps,
    to_seconds,
)
from sondalog.ala1.nvstore import NvStore as NvStore  # (re-exported: the engine, stores)
from sondalog.ala1.ondemand import OnDemand, measure_now
from sondalog.ala1.params import RESET_KEEPS, KeyInfo, storage_keys
from sondalog.ala1.parser import Plan
from sondalog.ala1.record import RecordMark, load_record
from sondalog.ala1.sampling import Outputs, Sampler
from sondalog.ala1.shared import Derived, derived_for
from sondalog.ala1.state_shared import NotedIdentity, fixed_defaults, shared_tables
from sondalog.ala1.tokens import format_stamp
from sondalog.protocol.tables import TableSet

log = logging.getLogger("sondalog.ala1.state")

#: Keys whose change reconfigures sampling, outputs or the record.
_LIVE_PREFIXES = ("channel", "device", "output", "global timing", "file", "record type")


class NeedWait(Exception):
    """The line must wait: a measurement needs its switch advance or a DS18B20 conversion
    first (§6.5.13: module time), or a ``pause`` header asks for it (§8.5.1: line time)."""

    def __init__(self, seconds: float, *, line_time: bool = False) -> None:
        super().__init__(seconds)
        self.seconds = seconds
        self.line_time = line_time


class ModuleState:
    """What one ALA1 module remembers."""

    def __init__(
        self,
        identity: Identity,
        store: NvStore,
        host_now: float,
        hardware: Hardware | None = None,
    ) -> None:
        self.identity = identity
        self.store = store
        self.hardware: Hardware = hardware or NoHardware()
        self.keys: dict[str, KeyInfo] = storage_keys(identity.version)
        self._fixed = fixed_defaults(identity.version)
        values, offset = store.load()
        self.values = {k: v for k, v in values.items() if k in self.keys}
        if offset is None:
            offset = to_seconds(FACTORY_DATE) - host_now
            store.commit({}, offset, seen=host_now)
        else:
            seen = store.last_seen()
            if seen is not None and host_now < seen:
                # An accelerated clock (--speed) restarted behind the last time the module
                # saw: its clock continues from there instead of running backwards.
                offset += seen - host_now
                store.commit({}, offset, seen=host_now)
        self.clock_offset = offset
        self.counters = [0, 0, 0, 0]
        self.measurer = Measurer(self.hardware)
        files = store.load_files()
        self.measurer.tables = shared_tables(files.get("list", b""), files.get("data", b""))
        self.record = load_record(store)  # (a store's older rows loaded when read: issue 24)
        self.outputs = Outputs(self.hardware)
        self.sampler = Sampler(self.measurer, self.outputs)
        self.on_demand = OnDemand(
            self.channel_config, self.measurer, self.outputs, self.sampler.faults
        )
        self.conversions: dict[int, float] = {}  # channel -> module time a DS18B20 is ready
        self._names: dict[str, int] | None = None
        #: What the committed values determine (typed channel configurations, dependent
        #: factory values: speed, issue 11), shared with every module of the same values
        #: (issue 24); let go whenever a parameter commits (:meth:`forget_values`).
        self._derived: Derived | None = None
        self._personal: dict[str, str] = {}  # dependent factory values that read the identity
        #: Parsed read-only lines (the interpreter's, issue 11): parsing depends on committed
        #: values only (channel max number, command names), so it holds until they change.
        self.plans: dict[str, Plan] = {}
        #: The sampler's next event (module time) while nothing changed it; None: unknown.
        self._event: tuple[float | None] | None = None
        self.generation = 0  # counts committed changes of message parameters or the clock
        self.message_runs: list[int] = []  # `write message N run 1` (§6.14.8), in order
        self._prepared: float | None = None
        #: The com device is a modem, but none answers: the line works as ``local``.
        self.modem_absent = False
        self._repair(host_now)
        self.configure(host_now)

    def _repair(self, host_now: float) -> None:
        """Values in the memory that cannot be used go back to their factory values, each
        reported; the module never starts mute (issue 9, DESIGN.md point 6). Found usable,
        they are so for every module of these values unless a check read the serial number:
        checked once for all (issue 24: a fleet starting)."""
        if (derived := self.derived()).memo.get("usable"):
            return
        view = _SharedView(self, host_now)
        bad: dict[str, str | None] = {}
        for key, value in self.values.items():
            info = self.keys[key]
            try:
                info.leaf.vtype.check_stored(value, view, info.indices)
            except Exception as exc:
                log.error(
                    "stored %s = %r cannot be used (%s): factory value restored", key, value, exc
                )
                bad[key] = None
        if bad:
            self.store.commit(bad, None, seen=host_now)
            for key in bad:
                del self.values[key]
            self.forget_values()
        elif not view.personal:
            derived.memo["usable"] = True

    # -- time --------------------------------------------------------------------------------
    def module_seconds(self, host_now: float) -> float:
        """The module clock; it stops at the end of year 9999 (and never precedes year 1)."""
        return min(max(host_now + self.clock_offset, CLOCK_MIN), CLOCK_MAX)

    def module_time(self, host_now: float) -> datetime:
        return from_seconds(self.module_seconds(host_now))

    # -- parameters --------------------------------------------------------------------------
    def get(self, key: str) -> str:
        """A committed value (outside any line); a factory value that depends on others is
        cached until a commit changes values, shared with the modules of the same values
        unless it reads the identity (issue 24)."""
        if (value := self.values.get(key)) is None and (value := self._fixed.get(key)) is None:
            derived = self.derived()
            if (value := derived.settings.get(key)) is None and (
                value := self._personal.get(key)
            ) is None:
                view = _SharedView(self)
                value = view.default(key)
                (self._personal if view.personal else derived.settings)[key] = value
        return value

    def derived(self) -> Derived:
        """What the committed values determine, shared (:mod:`sondalog.ala1.shared`)."""
        if (derived := self._derived) is None:
            identity = self.identity
            derived = self._derived = derived_for(identity.version, identity.device, self.values)
        return derived

    def command_names(self) -> dict[str, int]:
        """Named commands (§6.8.2): name -> number, the non-empty names only (cached)."""
        if self._names is None:
            names: dict[str, int] = {}
            for number in range(self.identity.limits.commands, 0, -1):
                name = self.get(f"command {number} name")
                if name:
                    names[name] = number  # the lowest number wins a duplicated name
            self._names = names
        return self._names

    setting = get  # a committed value read on every command (``com speed``)

    def forget_values(self) -> None:
        """Committed values changed: drop everything computed from them (issue 11)."""
        self._names = None
        self._derived = None
        self._personal.clear()
        self.plans.clear()
        self.on_demand.forget()

    def channel_config(self, ch: int) -> ChannelConfig:
        """Channel ``ch``'s typed configuration from the committed parameters (cached and
        shared, unless it reads the identity)."""
        configs = self.derived().configs
        if (cfg := configs.get(ch)) is None:
            view = _SharedView(self)
            cfg = channel_config(view, ch)
            if not view.personal:
                configs[ch] = cfg
        return cfg

    def begin(self, host_now: float) -> Transaction:
        return Transaction(self, host_now)

    def configure(self, host_now: float) -> None:
        """Apply committed parameters to sampling, outputs, the record and the tables."""
        view = self  # the committed values (shared, issue 24)
        max_number = int(view.get("channel max number"))
        self._event = None
        configs = [self.channel_config(ch) for ch in range(1, max_number + 1)]
        now = math.floor(self.module_seconds(host_now))
        self.sampler.configure(configs, max_number, now)
        self.measurer.timing = int(view.get("global timing"))
        outputs = self.outputs
        for n in range(1, self.identity.limits.outputs + 1):
            outputs.manual[n] = view.get(f"output {n} value")
            outputs.usable[n] = view.get(f"output {n} device") != "0"
        outputs.update(float(now), self.clock_offset)
        self.record.reconfigure(
            int(view.get("file record size")), view.get("record type") == "CYCLIC"
        )
        self._prepare()

    # -- files -------------------------------------------------------------------------------
    def write_file(self, area: str, data: bytes) -> None:
        """Place a table file (``list`` or ``data``) in the memory (§6.15, §6.16)."""
        if area not in ("list", "data"):
            raise ValueError(f"unknown file area {area!r}")
        size = int(self.get(f"file {area} size"))
        if len(data) > size:
            raise ValueError(f"{len(data)} bytes do not fit the {area} area of {size}")
        self.store.write_file(area, data)
        files = self.store.load_files()
        self.measurer.tables = TableSet(files.get("list", b""), files.get("data", b""))

    # -- sampling ----------------------------------------------------------------------------
    def run_sampling(self, host_now: float) -> None:
        """Take every scheduled sample up to ``host_now`` and store the rows (§6.5.14)."""
        if self._event is not None and self._event[0] is None:
            return  # nothing is scheduled (and nothing changed since that was found)
        target = self.module_seconds(host_now)
        event = self._next_event()
        if event is None or event > target:
            # Nothing due: the outputs are as the last event, measurement or configuration
            # left them (each of those updates them and forgets the cached event).
            return
        mark = self.record.mark()
        try:
            self._event = None
            self.sampler.run_until(target, self.clock_offset, self._store_row, self._store_rows)
            changes = self.record.take_changes()
            if changes is not None:
                self.store.commit_scheduled(changes, host_now)  # group commit (issue 11)
        except BaseException:
            self.record.rollback(mark)
            raise
        self._prepare()

    def _prepare(self) -> None:
        """Tell the hardware when the next sampling instant is (asynchronous acquisition)."""
        upcoming = self.next_event_host()
        if upcoming is not None and upcoming != self._prepared:
            self._prepared = upcoming
            self.hardware.prepare(upcoming)

    def _store_row(self, module_second: int, fields: list[str]) -> None:
        self.record.append(stamps([module_second])[0], "1," + ",".join(fields))

    def _store_rows(self, seconds: list[int], fields: list[list[str]]) -> None:  # (issue 24)
        self.record.append_many(stamps(seconds), ["1," + ",".join(f) for f in fields])

    def _next_event(self) -> float | None:
        """The sampler's next event, computed once per change (issue 11)."""
        cached = self._event
        if cached is None:
            cached = self._event = (self.sampler.next_event(),)
        return cached[0]

    def forget_schedule(self) -> None:
        """Sampling, switch or hold state changed outside the sampler's own run."""
        self._event = None

    def next_event_host(self) -> float | None:
        event = self._next_event()
        if event is None or event > CLOCK_MAX:
            return None  # past the end of the calendar nothing is ever due
        return event - self.clock_offset


class Transaction:
    """One command line's view of the module (implements :class:`~.model.View`)."""

    __slots__ = (
        "_mark", "changes", "clock", "deferred", "host_now", "identity", "record", "released",
        "reset_all", "runs", "state", "transfer", "waits",
    )  # fmt: skip

    def __init__(self, state: ModuleState, host_now: float) -> None:
        self.state = state
        self.identity = state.identity
        self.record = state.record
        self.host_now = host_now
        self.changes: dict[str, str | None] = {}
        self.reset_all = False
        self.clock: datetime | None = None
        self.waits: list[float] = []
        self.released = False  # `write com close` ran (§6.11.8)
        self.transfer: tuple[str, bool] | None = None  # (area, reading) of a special command
        self.runs: list[int] = []  # messages started by this line (§6.14.8)
        #: last-read points a `shift` moves only after a delivery (§6.8.4.1); None: at once
        self.deferred: dict[str, str] | None = None
        #: The record as it was before this line changed it (None: unchanged so far).
        self._mark: RecordMark | None = None

    def default(self, key: str) -> str:
        info = self.state.keys[key]
        return info.leaf.default_for(self, info.indices)

    def get(self, key: str) -> str:
        if key in self.changes:
            value = self.changes[key]
        elif self.reset_all and key not in RESET_KEEPS:
            value = None
        else:
            value = self.state.values.get(key)
        return self.default(key) if value is None else value

    def set(self, key: str, value: str) -> None:
        if key not in self.state.keys:
            raise KeyError(key)
        self.changes[key] = value
        if self.deferred:
            self.deferred.pop(key, None)  # an explicit write is not deferred

    def move_point(self, key: str, value: str) -> None:
        self.set(key, value)
        if self.deferred is not None:
            self.deferred[key] = value

    def run_message(self, number: int) -> None:
        self.runs.append(number)

    def reset(self, keep: tuple[str, ...]) -> None:
        self.reset_all = True
        for key in list(self.changes):
            if key not in keep:
                self.changes[key] = None

    def now(self) -> datetime:
        if self.clock is not None:
            return self.clock
        return self.state.module_time(self.host_now)

    def set_clock(self, moment: datetime) -> None:
        self.clock = moment

    def clear_record(self) -> None:
        self._keep_mark()
        self.record.clear()

    def release_line(self) -> None:
        self.released = True

    def start_transfer(self, area: str, *, reading: bool) -> None:
        if self.transfer is not None:
            raise CommandError("one transfer per line")
        self.transfer = (area, reading)

    # -- measurement and rows ------------------------------------------------------------------
    def measure(self, ch: int) -> str:
        """§6.5.8: measure channel ``ch`` now; a switched or DS18B20 input may need time."""
        return measure_now(self, ch)

    def measure_many(self, channels: list[int]) -> list[str]:
        """§6.5.8: :meth:`measure` of several channels, at once when they allow it."""
        if not self.changes and not self.reset_all:
            many = self.state.on_demand.many(tuple(channels))
            if many is not None:
                return many(self.host_now)
        return [measure_now(self, ch) for ch in channels]

    def channel_state(self, ch: int) -> tuple[str, str]:
        run = self.state.sampler.runs.get(ch)
        if run is None:
            return "", ""
        sample = format_value(run.cfg, run.sample) if run.sampled else ""
        return sample, run.recorded or ""

    def append_row(self, row_type: int, body: str) -> None:
        """Store a row of type ``row_type`` written now (§9)."""
        self._keep_mark()
        self.record.append(format_stamp(self.now()), f"{row_type},{body}")

    def _keep_mark(self) -> None:
        """Before the line's first change of the record: what a rollback goes back to."""
        if self._mark is None:
            self._mark = self.record.mark()

    # -- end of the line -----------------------------------------------------------------------
    def rollback(self) -> None:
        if self._mark is not None:
            self.record.rollback(self._mark)

    def commit(self) -> None:
        """Make the line's effects durable, then visible."""
        state = self.state
        changes = dict(self.changes)
        for key in self.deferred or ():
            del changes[key]  # committed after the delivery (§6.8.4.1)
        if self.reset_all:
            for key in state.values:
                if key not in RESET_KEEPS and key not in changes:
                    changes[key] = None
        offset = None
        if self.clock is not None:
            offset = to_seconds(self.clock) - self.host_now
        record = self.record.take_changes()
        if changes or offset is not None or record is not None:
            state.store.commit(changes, offset, record, seen=self.host_now)
        if changes:  # (a line of reads changes nothing: none of this runs)
            for key, value in changes.items():
                if value is None:
                    state.values.pop(key, None)
                else:
                    state.values[key] = value
            state.forget_values()
        if offset is not None or (changes and any(key.startswith("message ") for key in changes)):
            state.generation += 1
        state.message_runs.extend(self.runs)
        if offset is not None:
            state.clock_offset = offset
        if self.reset_all or (changes and any(key.startswith(_LIVE_PREFIXES) for key in changes)):
            state.configure(self.host_now)
        if offset is not None:
            state.sampler.reschedule(math.floor(state.module_seconds(self.host_now)))
            state.forget_schedule()


class _SharedView(Transaction):
    """The committed values, noting whether what is computed from them read the identity
    beyond its version and limits (then it is the module's own, not shared:
    :mod:`sondalog.ala1.shared`)."""

    __slots__ = ("noted",)

    def __init__(self, state: ModuleState, host_now: float = 0.0) -> None:
        self.noted = NotedIdentity(state.identity)
        super().__init__(state, host_now)

    @property
    def personal(self) -> bool:
        return self.noted.personal

    @property
    def identity(self) -> Identity:
        return cast(Identity, self.noted)

    @identity.setter
    def identity(self, identity: Identity) -> None:
        pass  # (Transaction.__init__: read from the state above)
