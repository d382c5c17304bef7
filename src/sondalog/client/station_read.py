"""Reading a logger's whole configuration in few, full lines (issue 24; §3.3, §6.5.2, §7).

The settings of :mod:`sondalog.client.station_schema` are read with as few bytes and lines as
the protocol allows, each answer split without asking again:

- **§7.2 chaining after the first keyword**: ``read message 1 address 2 address 1 of channel
  value ...``: a command with the same first keyword as the one before it leaves out ``read``
  and that keyword; any other starts with ``read`` (§7.1). Keywords, indices and channel lists
  are strings of known length, written without the spaces between them (§4.2.2, §4.1:
  ``readchannel1value``). Lines hold at most 120 characters (§3.4.1, less the ``iaddress``
  header a guarded logger needs, §8.6.1);
- **channel lists** (§6.5.2): ``read channel 010203040506070809101112 sampling period`` answers
  the twelve values in one line, joined by commas. An answer line may not be longer than 100
  characters (§3.3), so a list holds as many channels as the widest value the setting can read
  back allows (a date 6, a number in any format 3, a two-input number 2; a channel address of
  2.10, 64-bit, 2). Strings (a channel's name, its tables) are never listed: a comma in one
  would make the split ambiguous; they are chained one per channel;
- every command of a line answers exactly one data line, so a line's answer is known to be
  its commands' count of lines and ``OK``: the answers are counted as raw bytes arrive (the
  client is woken once they are in, :mod:`sondalog.client.answer_wait`) and split only when
  they are needed (:meth:`ReadPlan.values`). A refused line (the command line and ``ERROR``,
  §3.3.1) is recognised as such, so a logger that refuses one does not leave the reader
  waiting;
- the lines flow in a window (issue 24): :data:`BATCH` at once (as many as the
  one-command-a-line reader sent ahead), then :data:`STEP` more each time the answers to as
  many are in. A logger never holds more than :data:`BATCH` unanswered lines, and the
  answers never wait for a round trip: one round trip a read, where batches took three.

2.10: 841 settings in 80 lines (9.0 KB of commands, one round trip with the identity) where
one command a setting took 191 lines (23 KB, 7 round trips); 1.16: 283 settings in 22 lines
(2.3 KB, one round trip; 62 lines, 7.4 KB before). The lines of a version are worked out once.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import MAX_LINE, ClientError
from sondalog.client.station_grammar import (
    LIMITS,
    ChannelAddress,
    Date,
    Format,
    Grammar,
    Integer,
    Limits,
    Number,
    OneOf,
    Period,
    _bound,
)
from sondalog.client.station_schema import SETTINGS, Setting

#: §3.3: no answer line may be longer than this.
MAX_ANSWER = 100
#: Lines sent ahead of their answers at most (as many as the one-command-a-line reader
#: sent ahead): a logger's input is not ours to fill.
BATCH = 32
#: Lines sent each time the answers to as many are in (the window moves on).
STEP = 16
#: Seconds the client lets the answers gather before it reads them again (a logger writes
#: a line's answer at a time): ~50 reads and wakes of a 2.10 read become a few; the end is
#: seen at most this much later (:class:`~sondalog.client.answer_wait.CountedWait`). Only
#: for reads of more than :data:`BATCH` lines: a shorter one (1.16's 22 lines) is mostly in
#: by the reader's first wake, and a pause would add a wake (measured).
GATHER = 0.001
_OK = "OK"
_ERROR = "ERROR"


def read_command(setting: Setting, n: int) -> str:
    """The one ``read`` of a setting's instance (``read channel 3 device all``)."""
    return f"read {setting.name(n)}{' all' if setting.dual else ''}"


def clean(setting: Setting, text: str) -> str:
    """A read-back value without the padding of its number format (§4.3.5)."""
    if isinstance(setting.grammar, Number):
        return ",".join(part.strip() for part in text.split(","))
    return text


@dataclass(frozen=True, slots=True)
class Part:
    """One data line of an answer: the setting instances it reads back, in order (several:
    a channel list, their values joined by commas, two each for a two-input setting)."""

    setting: Setting | None  # None: not a setting (the identity), taken as it is
    names: tuple[str, ...]

    def take(self, text: str, out: dict[str, str]) -> None:
        if self.setting is None or len(self.names) == 1:
            out[self.names[0]] = text if self.setting is None else clean(self.setting, text)
            return
        parts = text.split(",")
        each = 2 if self.setting.dual else 1
        if len(parts) != each * len(self.names):
            raise ClientError(f"{len(parts)} values for {len(self.names)} channels: {text!r}")
        if isinstance(self.setting.grammar, Number):
            parts = [part.strip() for part in parts]
        for i, name in enumerate(self.names):
            out[name] = ",".join(parts[i * each : (i + 1) * each])


@dataclass(frozen=True, slots=True)
class Line:
    """One request line and the data lines its answer holds."""

    text: str
    parts: tuple[Part, ...]


def _decimals(setting: Setting) -> int:
    """Decimals a number reads back with: a fixed format's, else the most a format has."""
    if setting.fmt is not None:
        try:
            return int(setting.fmt({}, 1)[2])
        except KeyError:  # the format is another setting's value
            pass
    return 9


def width(setting: Setting, limits: Limits) -> int | None:
    """The widest value a setting can read back (§4.3, §11), or None for a string."""
    grammar: Grammar = setting.grammar
    match grammar:
        case OneOf():
            wide = max(len(str(option)) for option in grammar.options)
        case Integer():
            wide = len(str(_bound(grammar.hi, limits)))
        case ChannelAddress():
            wide = len(str(limits.channel_address_max))
        case Format():
            wide = 3
        case Period():
            wide = 6
        case Date():
            wide = 14
        case Number():  # sign, 16 digits (below 10^15, rounded up), point, decimals
            wide = 18 + _decimals(setting)
        case _:
            return None
    return 2 * wide + 1 if setting.dual else wide


#: A command as chaining sees it: its first keyword, the rest, what its answer line holds.
_Command = tuple[str, str, Part]


def _channel_commands(setting: Setting, limits: Limits) -> list[_Command]:
    key = setting.pattern.removeprefix("channel {ch} ") + (" all" if setting.dual else "")
    count = setting.count(limits)
    wide = width(setting, limits)
    per_line = 1 if wide is None else max(1, (MAX_ANSWER + 1) // (wide + 1))
    out: list[_Command] = []
    for first in range(1, count + 1, per_line):
        numbers = range(first, min(first + per_line, count + 1))
        names = tuple(setting.name(n) for n in numbers)
        which = str(first) if len(numbers) == 1 else "".join(f"{n:02d}" for n in numbers)
        out.append(("channel", f"{which} {key}", Part(setting, names)))
    return out


def _commands(setting: Setting, limits: Limits) -> list[_Command]:
    if setting.numbered and setting.group == "channel":
        return _channel_commands(setting, limits)
    out: list[_Command] = []
    for n in range(1, setting.count(limits) + 1):
        first, rest = read_command(setting, n).removeprefix("read ").split(" ", 1)
        out.append((first, rest, Part(setting, (setting.name(n),))))
    return out


def _tight(words: str) -> str:
    """``words`` without the spaces §4.2.2 allows to leave out: keywords, indices and channel
    lists are strings of known length; two numbers in a row keep theirs (§4.3.4)."""
    out = ""
    for word in words.split():
        if out and out[-1].isdigit() and word[0].isdigit():
            out += " "
        out += word
    return out


def _pack(commands: list[_Command], room: int) -> list[Line]:
    """Commands chained into lines of at most ``room`` characters (§7)."""
    lines: list[Line] = []
    text, parts, last = "", list[Part](), ""
    for first, rest, part in commands:
        more = _tight(rest if first == last else f"read {first} {rest}")
        if text and len(text) + len(more) + 1 > room:
            lines.append(Line(text, tuple(parts)))
            text, parts = "", []
            more = _tight(f"read {first} {rest}")
        text = _tight(f"{text} {more}")
        parts.append(part)
        last = first
    if text:
        lines.append(Line(text, tuple(parts)))
    return lines


def _same_in_every_version(setting: Setting) -> bool:
    """Unnumbered settings, devices and outputs: read by the same lines in every version."""
    if not setting.numbered:
        return True
    counts = {setting.count(limits) for limits in LIMITS.values()}
    return len(counts) == 1 and setting.group != "channel"


@dataclass(frozen=True)
class ReadPlan:
    """The lines that read every setting of a logger of ``version``: first those that are
    the same in every version (a reader that assumed the wrong one learns it from the first
    answers without a refusal), then the others."""

    version: str
    prefix: str
    lines: tuple[Line, ...]

    @functools.cached_property
    def names(self) -> tuple[str, ...]:
        """Every instance's name in the order of a station file (the manual's)."""
        limits = LIMITS[self.version]
        return tuple(s.name(n) for s in SETTINGS for n in range(1, s.count(limits) + 1))

    @functools.cached_property
    def sending(self) -> Sending:
        """:attr:`lines` as they are sent, worked out once."""
        return sending(self.lines, self.prefix)

    @functools.cached_property
    def identified(self) -> Sending:
        """:data:`IDENTIFY` and :attr:`lines` as they are sent: the identity first
        (:func:`read_config` with the version the logger had)."""
        return sending((IDENTIFY, *self.lines), self.prefix)

    def values(self, raw: bytes) -> dict[str, str]:
        """The settings in ``raw``, the answers to :attr:`lines` (file order); ClientError
        when they are not such answers."""
        texts = raw.decode("latin-1").split("\n")
        if texts.pop() != "":
            raise ClientError("the answers end in the middle of a line")
        read: dict[str, str] = {}
        at = 0
        for line in self.lines:
            end = at + len(line.parts)
            answer = [text.removesuffix("\r") for text in texts[at : end + 1]]
            if len(answer) != len(line.parts) + 1 or answer[-1] != _OK:
                raise ClientError(f"the logger did not answer {line.text!r} as expected")
            for part, text in zip(line.parts, answer, strict=False):
                part.take(text, read)
            at = end + 1
        if at != len(texts):
            raise ClientError(f"{len(texts) - at} lines more than the answers hold")
        return {name: read[name] for name in self.names}


#: §6.3.1, §6.3.3: the identity, first in a read that assumes the version.
IDENTIFY = Line(
    "read i version read i snumber", (Part(None, ("i version",)), Part(None, ("i snumber",)))
)


@functools.lru_cache(maxsize=16)
def read_plan(version: str, prefix: str = "") -> ReadPlan:
    """The :class:`ReadPlan` of ``version`` for lines that start with ``prefix``."""
    limits = LIMITS[version]
    room = MAX_LINE - len(prefix)
    common = [s for s in SETTINGS if _same_in_every_version(s)]
    other = [s for s in SETTINGS if not _same_in_every_version(s)]
    lines = []
    for group in (common, other):
        lines += _pack([c for s in group for c in _commands(s, limits)], room)
    return ReadPlan(version, prefix, tuple(lines))


def _payload(prefix: str, lines: Sequence[Line]) -> bytes:
    return "".join(f"{prefix}{line.text}\r" for line in lines).encode("latin-1")


def _answered(raw: bytes, lines: Sequence[Line], prefix: str) -> tuple[int, bool]:
    """How many of ``lines`` (in order) have whole answers in ``raw``, refused ones (the
    line and ``ERROR``, §3.3.1) included; and whether ``raw`` is exactly their answers."""
    texts = [t.removesuffix("\r") for t in raw.decode("latin-1").split("\n")[:-1]]
    at = 0
    for done, line in enumerate(lines):
        count = len(line.parts)
        if at + count < len(texts) and texts[at + count] == _OK:
            at += count + 1
        elif texts[at : at + 2] == [(prefix + line.text)[:MAX_LINE], _ERROR]:
            at += 2
        else:
            return done, False
    return len(lines), at == len(texts)


@dataclass(frozen=True, slots=True)
class Sending:
    """``lines`` as they are sent: the first :data:`BATCH` at once, then :data:`STEP` more
    each time the answers to as many are in (``pieces``: the line ends those answers hold,
    the lines they answer, the bytes); the line ends all the answers hold; the most bytes
    they can be (answer lines of at most :data:`MAX_ANSWER`, §3.3; a refused line echoed):
    a peer that talks on past it is not answering."""

    lines: tuple[Line, ...]
    prefix: str
    payload: bytes
    pieces: tuple[tuple[int, int, bytes], ...]
    expected: int
    most: int

    def answered(self, raw: bytes, sent: int) -> tuple[int, bool]:
        """:func:`_answered` of the lines in the first ``sent`` pieces (the payload one)."""
        count = min(BATCH + (sent - 1) * STEP, len(self.lines))
        return _answered(raw, self.lines[:count], self.prefix)


def sending(lines: Sequence[Line], prefix: str) -> Sending:
    """:class:`Sending` of ``lines`` (a :class:`ReadPlan` keeps its own)."""
    lines = tuple(lines)
    ends = [0]
    for line in lines:
        ends.append(ends[-1] + len(line.parts) + 1)
    pieces = []
    for start in range(BATCH, len(lines), STEP):
        answered = start + STEP - BATCH  # then BATCH lines are unanswered with these
        pieces.append((ends[answered], answered, _payload(prefix, lines[start : start + STEP])))
    most = sum(len(prefix) + len(line.text) + 9 for line in lines) + ends[-1] * (MAX_ANSWER + 2)
    return Sending(lines, prefix, _payload(prefix, lines[:BATCH]), tuple(pieces), ends[-1], most)


async def exchange(client: Ala1Client, lines: Sequence[Line], prefix: str = "") -> bytes:
    """Send ``lines`` and return their raw answers, CR LF and all: each line's data lines
    and ``OK``, or the line and ``ERROR`` when it was refused (seen as soon as the answers
    after it are in). At most :data:`BATCH` lines are sent ahead of their answers.

    Raises :class:`NoAnswer` or :class:`IncompleteAnswer` when the answers stop short (the
    timeout is the client's, from the last byte received) or grow past what they can be."""
    return await _exchange(client, sending(lines, prefix))


async def _exchange(client: Ala1Client, send: Sending) -> bytes:
    """The answers to ``send``'s lines; the client is woken once a piece sent
    (:meth:`~sondalog.client.ala1.Ala1Client.read_counted`), not for each piece received."""
    gather = GATHER if send.pieces else 0.0  # a short read is in by the first wake anyway
    return await client.read_counted(
        send.payload, send.expected, send.most, send.answered, more=send.pieces, gather=gather
    )


@dataclass(frozen=True)
class ConfigRead:
    """A whole configuration as read: the logger's identity and the raw answers."""

    version: str
    serial: str
    plan: ReadPlan
    raw: bytes

    @functools.cached_property
    def digest(self) -> bytes:
        """SHA-256 of the identity and the raw answers: equal digests, equal settings."""
        digest = hashlib.sha256(f"{self.version}\n{self.serial}\n".encode())
        digest.update(self.raw)
        return digest.digest()

    def values(self) -> dict[str, str]:
        return self.plan.values(self.raw)


def _identity(raw: bytes) -> tuple[str, str, int]:
    """Version, serial number and the end of the answer to :data:`IDENTIFY` in ``raw``."""
    texts = raw.split(b"\n", 3)
    answer = [t.removesuffix(b"\r").decode("latin-1") for t in texts[:3]]
    if len(texts) < 4 or answer[2] != _OK or answer[0] not in LIMITS:
        raise ClientError(f"not an ALA1 logger: it answered {raw[:60]!r} to read i version")
    return answer[0], answer[1], len(raw) - len(texts[3])


async def read_config(client: Ala1Client, version: str | None, prefix: str = "") -> ConfigRead:
    """The identity and every setting of the logger on ``client``'s line.

    With the ``version`` a logger had before, the identity is read with the settings, in
    one flow of lines (one round trip): those same in every version come first, so a logger
    of the other version answers them too (and reads or refuses the others: nothing is
    written); its settings are then read again with its own lines. Without it, the identity
    is read first (one more round trip)."""
    if version is not None:
        raw = await _exchange(client, read_plan(version, prefix).identified)
        found, serial, at = _identity(raw)
        if found == version:
            return ConfigRead(found, serial, read_plan(found, prefix), raw[at:])
    else:
        found, serial, _ = _identity(await exchange(client, [IDENTIFY], prefix))
    plan = read_plan(found, prefix)  # another logger at the line: its own lines
    return ConfigRead(found, serial, plan, await _exchange(client, plan.sending))
