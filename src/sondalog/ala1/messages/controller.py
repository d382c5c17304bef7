"""Messages (§6.14): what triggers them, when they wait, and what they carry.

A message is *triggered* by its period (§6.14.4-5), by a sampling instant that wrote record
rows (``of record function yes``, §6.14.6), by its watched channel crossing a value
(``of channel``, §6.14.7) or by ``write message N run 1`` (§6.14.8). A triggered message
*waits* while its way out is busy (§6.14.9: the cable line for ``com device local``, the modem
for ``wavecom``) and while an earlier sending of it is still with a carrier; triggers that
arrive meanwhile merge into one sending. When it can go, its command (§6.14.3) runs exactly
as a line would run it (no echo; ``counter`` numbers lines across messages, §8.5.7) and the
answer becomes an :class:`~sondalog.ala1.outbox.Outgoing` in the :class:`Outbox`. A
``shift`` in that command moves its last-read point only when the carrier reports that every
destination got the message (§6.8.4.1): the point is kept aside until :meth:`Outbox.done`.

Times: triggers and periods follow the module clock (module seconds); the host time of a
trigger is remembered for the deadline the engine reports.
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass

from sondalog.ala1.interpreter import Answer, Interpreter
from sondalog.ala1.measure import format_value
from sondalog.ala1.messages.config import MessageConfig, destinations, is_local, load, off
from sondalog.ala1.messages.crossing import Crossing
from sondalog.ala1.messages.schedule import next_due
from sondalog.ala1.outbox import Outbox, Outgoing
from sondalog.ala1.sampling import ChannelRun
from sondalog.ala1.series import Samples
from sondalog.ala1.state import ModuleState, NeedWait

log = logging.getLogger(__name__)


@dataclass(slots=True)  # one per message and module: a fleet holds 40 a logger (issue 24)
class _Message:
    """One message's configuration and its RAM state."""

    config: MessageConfig
    due: float | None = None  # next periodic trigger, module seconds
    crossing: Crossing | None = None
    pending: float | None = None  # host time of the first trigger not yet sent
    body_at: float | None = None  # host time its command may run again (pause, sensors)
    paused: bool = False  # the command's `pause` is over
    flight: int | None = None  # ident of the sending a carrier has


@dataclass(frozen=True)
class _Flight:
    message: int
    moves: dict[str, tuple[str, str]]  # last-read key -> (value before, value after)


class Messages:
    """The message logic of one module; carriers take its sendings from ``outbox``."""

    def __init__(
        self,
        state: ModuleState,
        interpreter: Interpreter,
        outbox: Outbox,
        host_now: float,
        *,
        line_time_scale: float = 1.0,
    ) -> None:
        self.state = state
        self.interpreter = interpreter
        self.outbox = outbox
        self.scale = line_time_scale
        self._now = host_now
        self._generation: int | None = None
        self._offset: float | None = None
        self._messages: dict[int, _Message] = {}
        self._flights: dict[int, _Flight] = {}
        outbox.on_done(self._done)
        #: No message is scheduled, waiting or on its way: a command's step costs nothing.
        self._idle = False
        #: The messages a sampling instant concerns: of the record, or watching a channel.
        self._watching: list[tuple[int, _Message]] = []
        state.sampler.observer = self._sampled
        state.sampler.series_observer = self._sampled_series
        self._refresh(host_now)

    # -- configuration -------------------------------------------------------------------------
    def _refresh(self, host_now: float) -> None:
        """Reload the configurations after a committed change; restart the schedules of
        changed messages, and of all when the clock was set."""
        state = self.state
        if state.generation == self._generation and state.clock_offset == self._offset:
            return
        clock_set = self._offset is not None and state.clock_offset != self._offset
        self._generation, self._offset = state.generation, state.clock_offset
        after = math.floor(state.module_seconds(host_now))
        # the same for every module with the same values: made once (issue 24)
        configs = state.derived().shared("message configs", lambda: _configs(state))
        for number, config in enumerate(configs, 1):
            message = self._messages.get(number)
            if message is None:
                message = self._messages[number] = _Message(config)
                if config.period == "000000" and config.channel_function == "NO":
                    continue  # off, watching nothing: as the factory left it (start-up)
            elif message.config == config and not clock_set:
                continue
            if message.crossing is None or message.config.watches != config.watches:
                message.crossing = _watcher(config)
            message.config = config
            message.due = next_due(config.period, config.start, after)
        self._idle = self._nothing_to_do()
        self._watching = [
            (number, message)
            for number, message in self._messages.items()
            if message.config.of_record or message.crossing is not None
        ]

    def _nothing_to_do(self) -> bool:
        return all(
            m.due is None and m.pending is None and m.flight is None and m.crossing is None
            for m in self._messages.values()
        )

    # -- triggers ------------------------------------------------------------------------------
    def trigger(self, number: int, host_time: float) -> None:
        """Message ``number`` should be sent; merged with a sending already waiting."""
        message = self._messages.get(number)
        if message is not None and message.pending is None:
            message.pending = host_time
            self._idle = False

    def _sampled(self, t: int, runs: list[ChannelRun], wrote: bool) -> None:
        """The sampler's observer: one sampling instant (module second ``t``)."""
        if not self._watching:
            return
        host_t = t - self.state.clock_offset
        sampled = {run.cfg.number: run for run in runs}
        for number, message in self._watching:
            if wrote and message.config.of_record:
                self.trigger(number, host_t)
            crossing = message.crossing
            run = sampled.get(message.config.channel)
            if (
                crossing is not None
                and run is not None
                and crossing.sample(format_value(run.cfg, run.sample))
            ):
                self.trigger(number, host_t)

    def _sampled_series(self, wrote: list[int], samples: Samples) -> None:
        """The sampler's series observer: many instants at once, as :meth:`_sampled` instant
        by instant (a waiting message keeps its first trigger; every sample of a watched
        channel moves its crossing)."""
        if not self._watching:
            return
        offset = self.state.clock_offset
        for number, message in self._watching:
            first = wrote[0] if wrote and message.config.of_record else None
            crossing = message.crossing
            got = samples.get(message.config.channel)
            if crossing is not None and got is not None:
                cfg, times, values = got
                k = crossing.first_in(values, functools.partial(format_value, cfg), cfg.format)
                if k is not None and (first is None or times[k] < first):
                    first = times[k]
            if first is not None:
                self.trigger(number, first - offset)

    # -- sending -------------------------------------------------------------------------------
    def blocked(self, local_ready: bool) -> bool:
        """§6.14.9: the way out is busy (the cable line, or the modem)."""
        if is_local(self.state):
            return not local_ready
        return self.outbox.modem_busy

    def step(self, host_now: float, *, local_ready: bool) -> None:
        """Take the triggers due at ``host_now`` and put what may go in the outbox.

        ``local_ready``: a cable line is attached and none blocks messages (§6.14.9.2)."""
        self._now = host_now
        self._refresh(host_now)
        state = self.state
        if self._idle and not state.message_runs:
            return
        module_now = state.module_seconds(host_now)
        for number, message in self._messages.items():
            if message.due is not None and message.due <= module_now:
                self.trigger(number, message.due - state.clock_offset)
                config = message.config
                message.due = next_due(config.period, config.start, math.floor(module_now) + 1)
        if is_local(state):
            self._withdraw_modem_sendings()
        runs, state.message_runs = state.message_runs, []
        for number in runs:
            self.trigger(number, host_now)
        if self.blocked(local_ready):
            return
        for message in self._messages.values():
            if message.pending is None or message.flight is not None:
                continue
            if message.body_at is not None and host_now < message.body_at:
                continue
            self._send(message, host_now)
        state.message_runs.clear()  # a message's own command does not start messages
        self._idle = self._nothing_to_do()

    def _send(self, message: _Message, host_now: float) -> None:
        config = message.config
        where = destinations(self.state, config)
        if not where:
            message.pending = None  # nowhere to go: the trigger is spent
            return
        deferred: dict[str, str] = {}
        answer: Answer | None
        try:
            answer = self.interpreter.run_stored(
                config.command, host_now, paused=message.paused, deferred=deferred
            )
        except NeedWait as wait:  # §8.5.1 pause (line time), §6.5.13 sensors (module time)
            message.body_at = host_now + wait.seconds * (self.scale if wait.line_time else 1.0)
            message.paused = True
            return
        except Exception:  # DESIGN.md point 6: a message never stops the module
            log.exception("internal error running the command of message %d", config.number)
            answer = None
        message.pending, message.body_at, message.paused = None, None, False
        body = answer.data.decode("latin-1") if answer is not None else ""
        if not body:
            return  # nothing to say (a silent or empty command)
        ident = self.outbox.new_ident()
        moves = {key: (self.state.get(key), value) for key, value in deferred.items()}
        self._flights[ident] = _Flight(config.number, moves)
        message.flight = ident
        self.outbox.put(Outgoing(ident, config.number, where, body))

    def _withdraw_modem_sendings(self) -> None:
        """Back to ``com device local``: sendings no modem took are failed deliveries, so
        their messages go on the line at their next trigger."""
        for ident in list(self._flights):  # (local sendings never stay queued)
            if self.outbox.withdraw(ident) is not None:
                self._done(ident, False)

    def _done(self, ident: int, ok: bool) -> None:
        """A carrier finished: only a complete delivery moves the last-read points."""
        flight = self._flights.pop(ident, None)
        if flight is None:
            return
        message = self._messages.get(flight.message)
        if message is not None and message.flight == ident:
            message.flight = None
        if not ok:
            return
        state = self.state
        moves = {k: new for k, (old, new) in flight.moves.items() if state.get(k) == old}
        if moves:  # a point moved meanwhile by someone else stays where they put it
            txn = state.begin(self._now)
            for key, value in moves.items():
                txn.set(key, value)
            txn.commit()

    # -- time ----------------------------------------------------------------------------------
    def next_deadline(self, *, local_ready: bool) -> float | None:
        """Host time of the next periodic trigger, or of a waiting message that may go."""
        self._refresh(self._now)  # a change committed outside a step (an SMS command)
        if self._idle and not self.state.message_runs:
            return None
        offset = self.state.clock_offset
        deadlines = [m.due - offset for m in self._messages.values() if m.due is not None]
        waiting = [
            m.body_at if m.body_at is not None else m.pending
            for m in self._messages.values()
            if m.pending is not None and m.flight is None
        ]
        if waiting and not self.blocked(local_ready):  # blocked: woken by what unblocks
            deadlines.append(min(waiting))
        if self.state.message_runs:
            deadlines.append(self._now)
        return min(deadlines, default=None)


def _configs(state: ModuleState) -> tuple[MessageConfig, ...]:
    """Every message's configuration from the committed values."""
    configs = []
    for number in range(1, state.identity.limits.messages + 1):
        try:
            configs.append(load(state, number))
        except Exception as exc:  # DESIGN.md point 6: never stop the module
            log.error("message %d cannot be used (%s): it is off", number, exc)
            configs.append(off(number))
    return tuple(configs)


def _watcher(config: MessageConfig) -> Crossing | None:
    watches = config.watches
    if watches is None:
        return None
    function, _, value, hysteresis = watches
    return Crossing(function, value, hysteresis)
