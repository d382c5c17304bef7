"""The HCTMPS1 module core: bytes and time in, bytes and the next deadline out.

This is the sans-I/O heart of the sensor server (DESIGN.md points 1 and 2). A transport (the
virtual RS-485 bus of :mod:`sondalog.world.bus`) hands every received chunk of bytes and the current
clock time to :meth:`Hctmps1Module.handle`; it gets back the bytes to transmit now and the
time at which the module wants to be called again (a measurement completing, a delayed
broadcast reply falling due). The module never reads a clock, never sleeps and never touches
a socket. The only side effect is :meth:`EepromStore.save` on ``SAVEEE``, which returns once
the image is durable, before the reply is produced (DESIGN.md point 5).

Section numbers refer to the HCTMPS1 notes (docs/hctmps1-notes.md).
"""

from __future__ import annotations

import logging
import random
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace

from sondalog.hctmps1.eeprom import (
    FACTORY_PASSWORD,
    MAX_SUPERVISORS,
    EepromImage,
    EepromStore,
)
from sondalog.hctmps1.variants import SensorSource, Variant
from sondalog.protocol.hctmps1_frames import (
    Frame,
    FrameDecoder,
    encode_frame,
    is_valid_id,
    slot_time,
)

log = logging.getLogger(__name__)

#: The ``<connect>`` context ends after this long without a command from its owner (§4).
CONNECT_TIMEOUT = 300.0
#: This many wrong passwords within :data:`LOCKOUT_WINDOW` seconds ... (§4)
LOCKOUT_ATTEMPTS = 5
LOCKOUT_WINDOW = 60.0
#: ... make the module ignore ``CONNECT`` for this long (§4).
LOCKOUT_TIME = 60.0
#: Data frames waiting for a ``REPLY`` grant; the oldest is dropped beyond this (§2).
QUEUE_MAX = 32
#: At most this many entries in the temporary distribution list (§1).
MAX_TEMPORARY = 8
#: A broadcast is answered after 0 to ``BROADCAST_SLOTS - 1`` frame slots (§2).
BROADCAST_SLOTS = 16
#: Measurement cycle (§4 "Values").
DEFAULT_CYCLE = 10.0

OK = "<OK>"
FA = "<FA>"
EMPTY = "<EMPTY>"
GETVER = "HVER*1_00*V-2013.SVER*1_1*VI-2018"

_PRINTABLE_PASSWORD = frozenset(chr(c) for c in range(0x21, 0x7F)) - {"|", ","}
_SYMBOL_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")


def is_valid_password(text: str) -> bool:
    """1 to 16 printable characters without ``|``, ``,`` or space (§4)."""
    return 1 <= len(text) <= 16 and all(c in _PRINTABLE_PASSWORD for c in text)


def is_valid_symbol(text: str) -> bool:
    """1 to 8 characters of ``A-Z a-z 0-9 _`` (§4)."""
    return 1 <= len(text) <= 8 and all(c in _SYMBOL_CHARS for c in text)


@dataclass(frozen=True, slots=True)
class ModuleConfig:
    """How one module instance is set up (the site file's entry for it)."""

    factory_id: str
    variant: Variant
    cycle: float = DEFAULT_CYCLE
    slot: float = slot_time(9600)

    def __post_init__(self) -> None:
        if not is_valid_id(self.factory_id):
            raise ValueError(f"bad module ID {self.factory_id!r}")
        if self.cycle <= self.variant.conversion_time:
            raise ValueError("the measurement cycle must be longer than the conversion time")
        if self.slot < 0:
            raise ValueError("the broadcast slot time must not be negative")


@dataclass(frozen=True, slots=True)
class Output:
    """What :meth:`Hctmps1Module.handle` returns: bytes to send now, and when to call again."""

    data: bytes
    deadline: float | None


@dataclass(frozen=True, slots=True)
class _Queued:
    dst: str
    body: str


# A handler gets (module, requester, param, now) and returns the reply body, or None for no
# reply. A handler that returns a whole frame (REPLY) is special-cased below.
_Handler = Callable[["Hctmps1Module", str, "str | None", float], "str | None"]


class Hctmps1Module:
    """One HCTMPS1 sensor server (temperature or humidity variant)."""

    def __init__(
        self,
        config: ModuleConfig,
        sensor: SensorSource,
        eeprom: EepromStore,
        rng: random.Random,
        now: float,
    ) -> None:
        self.config = config
        self.variant = config.variant
        self._sensor = sensor
        self._eeprom = eeprom
        self._rng = rng
        self._decoder = FrameDecoder()
        # EEPROM settings: the saved image wins over the configured factory ID (§1).
        self.settings: EepromImage = eeprom.load() or self.factory_settings()
        # RAM state (§1): all of it starts empty at power-up.
        self.temporary: list[str] = []
        self.autonomous = False
        self.queue: deque[_Queued] = deque(maxlen=QUEUE_MAX)
        self.dropped = 0
        self._contexts: dict[str, float] = {}
        self._wrong_passwords: deque[float] = deque()
        self._locked_until = float("-inf")
        self._delayed: list[tuple[float, int, bytes]] = []
        self._seq = 0
        # Measurements: one at power-up, then one per cycle (§4 "Values").
        self._power_up = now
        self._cycles_done = 0
        self.value = self._measure(now, None)
        self.measurements = 0

    # -- public API ------------------------------------------------------------------------

    @property
    def module_id(self) -> str:
        """The ID the module answers to now."""
        return self.settings.module_id

    def factory_settings(self) -> EepromImage:
        """The settings of ``RESEE`` (§1): factory password, empty lists, no symbol."""
        return EepromImage(self.config.factory_id, FACTORY_PASSWORD, (), None)

    def connected(self, requester: str, now: float) -> bool:
        """True if ``requester`` holds a live ``<connect>`` context (§4)."""
        last = self._contexts.get(requester)
        if last is None:
            return False
        if now - last > CONNECT_TIMEOUT:
            del self._contexts[requester]
            return False
        return True

    def handle(self, data: bytes, now: float) -> Output:
        """Take received bytes (may be empty) at time ``now``; return what to send (§2, §4)."""
        self._advance(now)
        out = bytearray()
        for frame in self._decoder.feed(data):
            try:
                self._dispatch(frame, now, out)
            except Exception:  # DESIGN.md point 6: never stop the device loop
                log.exception("HCTMPS1 %s: error handling %r", self.module_id, frame)
        out += self._release_delayed(now)
        return Output(bytes(out), self.next_deadline())

    def next_deadline(self) -> float | None:
        """When the module next has something to do (measurement or delayed reply)."""
        deadline = self._next_completion()
        if self._delayed:
            deadline = min(deadline, self._delayed[0][0])
        return deadline

    # -- measurement -------------------------------------------------------------------------

    def _next_completion(self) -> float:
        k = self._cycles_done + 1
        return self._power_up + k * self.config.cycle + self.variant.conversion_time

    def _measure(self, t: float, previous: str | None) -> str:
        try:
            return self.variant.format(self.variant.convert(self._sensor(t)))
        except Exception:
            log.exception("HCTMPS1 %s: sensor failed at %s", self.config.factory_id, t)
            return previous if previous is not None else self.variant.format(0.0)

    def _advance(self, now: float) -> None:
        """Run the measurement cycles that completed by ``now`` (§4 "Values", AUTOON)."""
        cycle = self.config.cycle
        behind = int((now - self._next_completion()) // cycle)
        if behind > QUEUE_MAX:  # far behind (process stopped): only the last cycles matter
            skipped = behind - QUEUE_MAX
            self._cycles_done += skipped
            if self.autonomous:
                self.dropped += skipped * len(self._distribution())
        while (done := self._next_completion()) <= now:
            self._cycles_done += 1
            self.value = self._measure(done, self.value)
            self.measurements += 1
            if self.autonomous:
                self._queue_data()

    def _distribution(self) -> list[str]:
        """Supervisors then temporary-list members, each destination once (§4 PV, AUTOON)."""
        targets: list[str] = []
        for ident in (*self.settings.supervisors, *self.temporary):
            if ident not in targets:
                targets.append(ident)
        return targets

    def _queue_data(self) -> None:
        for target in self._distribution():
            if len(self.queue) == QUEUE_MAX:
                self.dropped += 1
            self.queue.append(_Queued(target, f"RPV.{self.value}"))

    # -- frames ------------------------------------------------------------------------------

    def _dispatch(self, frame: Frame, now: float, out: bytearray) -> None:
        my_id = self.module_id
        if frame.dst != my_id and not frame.is_broadcast:
            return  # not for us (§2)
        requester = frame.src
        if self.connected(requester, now):
            self._contexts[requester] = now  # any command keeps the context alive (§4)
        command = frame.command
        if command == "REPLY":
            reply = self._grant(frame, my_id)
        else:
            entry = _COMMANDS.get(command)
            if entry is None:
                return  # unknown command: no reply (§4)
            needs_connect, handler = entry
            if needs_connect and not self.connected(requester, now):
                return  # outside <connect>: no reply (§4)
            body = handler(self, requester, frame.param, now)
            if body is None:
                return
            reply = encode_frame(requester, my_id, f"R{command}.{body}")
        if reply is None:
            return
        if frame.is_broadcast:
            self._delay(reply, now)
        else:
            out += reply

    def _grant(self, frame: Frame, my_id: str) -> bytes | None:
        """``REPLY``: the oldest queued data frame, else ``RREPLY.NODATA`` (§4)."""
        if frame.param is not None:
            return None
        if self.queue:
            item = self.queue.popleft()
            return encode_frame(item.dst, my_id, item.body)
        return encode_frame(frame.src, my_id, "RREPLY.NODATA")

    def _delay(self, reply: bytes, now: float) -> None:
        """Answer a broadcast after 0 to 15 frame slots (§2)."""
        due = now + self._rng.randrange(BROADCAST_SLOTS) * self.config.slot
        self._seq += 1
        self._delayed.append((due, self._seq, reply))
        self._delayed.sort()

    def _release_delayed(self, now: float) -> bytes:
        out = b""
        while self._delayed and self._delayed[0][0] <= now:
            out += self._delayed.pop(0)[2]
        return out

    # -- commands (§4) -----------------------------------------------------------------------

    def _connect(self, requester: str, param: str | None, now: float) -> str | None:
        if now < self._locked_until:
            return None  # locked out: CONNECT is ignored (§4)
        if param is not None and param == self.settings.password:
            self._contexts[requester] = now
            return OK
        while self._wrong_passwords and now - self._wrong_passwords[0] > LOCKOUT_WINDOW:
            self._wrong_passwords.popleft()
        self._wrong_passwords.append(now)
        if len(self._wrong_passwords) >= LOCKOUT_ATTEMPTS:
            self._locked_until = now + LOCKOUT_TIME
            self._wrong_passwords.clear()
        return None  # wrong password: no reply, no hint (§4)

    def _disconnect(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self._contexts.pop(requester, None)
        return OK

    def _hello(self, requester: str, param: str | None, now: float) -> str | None:
        return self.variant.hello if param is None else None

    def _getver(self, requester: str, param: str | None, now: float) -> str | None:
        return GETVER if param is None else None

    def _reinit(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self.settings = self._eeprom.load() or self.factory_settings()
        return OK

    def _resee(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self.settings = self.factory_settings()
        return OK

    def _saveee(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self._eeprom.save(self.settings)  # durable before the reply leaves (DESIGN.md 5)
        return OK

    def _setmid(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or not is_valid_id(param):
            return FA
        # The reply still carries the old ID: it is encoded before the new one is used (§2).
        self.settings = replace(self.settings, module_id=param)
        return OK

    def _addsup(self, requester: str, param: str | None, now: float) -> str | None:
        sups = self.settings.supervisors
        if param is None or not is_valid_id(param):
            return FA
        if param in sups:
            return OK
        if len(sups) >= MAX_SUPERVISORS:
            return FA
        self.settings = replace(self.settings, supervisors=(*sups, param))
        return OK

    def _delsup(self, requester: str, param: str | None, now: float) -> str | None:
        sups = self.settings.supervisors
        if param is None or param not in sups:
            return FA
        self.settings = replace(self.settings, supervisors=tuple(s for s in sups if s != param))
        return OK

    def _listsup(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        return ",".join(self.settings.supervisors) or EMPTY

    def _addp(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or not is_valid_symbol(param):
            return FA
        self.settings = replace(self.settings, symbol=param)
        return OK

    def _delp(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or self.settings.symbol is None or param != self.settings.symbol:
            return FA
        self.settings = replace(self.settings, symbol=None)
        return OK

    def _listp(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        return self.settings.symbol or EMPTY

    def _newpw(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or not is_valid_password(param):
            return FA
        self.settings = replace(self.settings, password=param)
        return OK

    def _pv(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self._queue_data()
        return self.value

    def _csservon(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or not is_valid_id(param):
            return FA
        if param in self.temporary:
            return OK
        if len(self.temporary) >= MAX_TEMPORARY:
            return FA
        self.temporary.append(param)
        return OK

    def _csservoff(self, requester: str, param: str | None, now: float) -> str | None:
        if param is None or param not in self.temporary:
            return FA
        self.temporary.remove(param)
        return OK

    def _csservlist(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        return ",".join(self.temporary) or EMPTY

    def _autoon(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self.autonomous = True
        return OK

    def _autooff(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        self.autonomous = False
        return OK

    def _getmode(self, requester: str, param: str | None, now: float) -> str | None:
        if param is not None:
            return None
        return "MDISON" if self.autonomous else "MDISOF"


#: The command table of §4 as data: name -> (needs <connect>, handler). REPLY is special.
_COMMANDS: dict[str, tuple[bool, _Handler]] = {
    "CONNECT": (False, Hctmps1Module._connect),
    "DISCONNECT": (False, Hctmps1Module._disconnect),
    "HELLO": (False, Hctmps1Module._hello),
    "GETVER": (False, Hctmps1Module._getver),
    "REINIT": (True, Hctmps1Module._reinit),
    "RESEE": (True, Hctmps1Module._resee),
    "SAVEEE": (True, Hctmps1Module._saveee),
    "SETMID": (True, Hctmps1Module._setmid),
    "ADDSUP": (True, Hctmps1Module._addsup),
    "DELSUP": (True, Hctmps1Module._delsup),
    "LISTSUP": (True, Hctmps1Module._listsup),
    "ADDP": (True, Hctmps1Module._addp),
    "DELP": (True, Hctmps1Module._delp),
    "LISTP": (True, Hctmps1Module._listp),
    "NEWPW": (True, Hctmps1Module._newpw),
    "PV": (False, Hctmps1Module._pv),
    "CSSERVON": (False, Hctmps1Module._csservon),
    "CSSERVOFF": (False, Hctmps1Module._csservoff),
    "CSSERVLIST": (False, Hctmps1Module._csservlist),
    "AUTOON": (False, Hctmps1Module._autoon),
    "AUTOOFF": (False, Hctmps1Module._autooff),
    "GETMODE": (False, Hctmps1Module._getmode),
}

#: Every command name of §4, in the table's order.
COMMAND_NAMES: tuple[str, ...] = ("REPLY", *_COMMANDS)
#: Commands that need the ``<connect>`` context (§4).
CONNECT_COMMANDS: frozenset[str] = frozenset(n for n, (c, _) in _COMMANDS.items() if c)
