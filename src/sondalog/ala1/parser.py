"""The body of a command line, parsed without running it (§5, §6, §7): the switch, the
keywords down the parameter trie, indices and channel lists, modifiers (``all``, ``x``) and
values. Pure: a host tool can run it to explain why a line was refused.

A refusal raises :class:`~sondalog.ala1.rejection.Refused` (a ParseError: the module's answer
is the same error response) carrying a :class:`~sondalog.ala1.rejection.Rejection`: where,
the token, what the grammar takes there, the manual section. It is built only on refusal.
:func:`parse_line` parses a whole line (headers §8.2, body, chaining §7) without running it
and returns the rejection instead of raising it."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from sondalog.ala1.headers import HEADER_WORDS, Headers
from sondalog.ala1.model import Unavailable, View
from sondalog.ala1.params import ROOT, IndexSpec, Leaf, Node
from sondalog.ala1.rejection import Refused, Rejection, rejection_at
from sondalog.ala1.tokens import Cursor, ParseError
from sondalog.ala1.values import ChannelAddress, Indices, ParseCtx

SWITCHES = [("read",), ("write",)]
_SWITCH_WORDS = ("read", "write")


@dataclass
class Command:
    """One parsed body command."""

    switch: str  # "R" or "W"
    leaf: Leaf
    targets: list[Indices]
    all_inputs: bool = False
    hexadecimal: bool = False
    values: list[list[str]] = field(default_factory=list)
    arg: str | None = None
    at: int = 0  # where the value (or the read argument) starts in the line


@dataclass(frozen=True)
class Plan:
    """A parsed read-only line (issue 11): its header and body commands. Parsing depends on
    the committed values only, so a plan holds until they change
    (:meth:`~sondalog.ala1.state.ModuleState.forget_values`)."""

    headers: Headers
    commands: tuple[Command, ...]
    #: The answer, when it is as constant as the parse: every command reads stored values
    #: or the identity, and no header adds the time or a counter.
    answer: bytes | None = None


def parse_switch(cur: Cursor) -> str | None:
    word = cur.choose_word(_SWITCH_WORDS)
    return None if word is None else ("R" if word == "read" else "W")


def parse_command(cur: Cursor, switch: str, node: Node, view: View) -> tuple[Command, str | None]:
    begin = cur.pos
    first_word: str | None = None
    indices: Indices = {}
    channels: list[int] | None = None
    while True:
        word = cur.choose_word(node.words)
        if word is not None:
            if node is ROOT:
                first_word = word
            node = node.words[word]
            continue
        if node.index is not None:
            spec, child = node.index
            if spec.is_list:
                channels = _channels(cur, spec, view)
            else:
                indices[spec.name] = _index(cur, spec, view)
            node = child
            continue
        break
    leaf = node.leaves.get(switch)
    if leaf is None:
        raise _no_leaf(cur, begin, node, switch)
    if "{ch}" in leaf.pattern:
        if channels is None:
            channels = list(range(1, int(view.get("channel max number")) + 1))
        targets = [{**indices, "ch": c} for c in channels]
    else:
        targets = [indices]
    command = Command(switch, leaf, targets)
    _modifiers(cur, command)
    command.at = cur.pos
    try:
        if switch == "R":
            if leaf.read_arg is not None:
                command.arg = leaf.read_arg.parse(cur, ParseCtx(view, indices))
        else:
            _values(cur, command, view)
    except ParseError as exc:
        vtype = leaf.vtype if switch == "W" else leaf.read_arg
        raise rejection_at(
            cur.text,
            cur.pos,
            "value",
            str(exc),
            leaf.section,
            (vtype.kind,) if vtype else (),
            leaf.pattern,
            vtype,
        ) from None
    if leaf.unavailable:
        raise Unavailable(leaf.unavailable)
    return command, first_word


def _index(cur: Cursor, spec: IndexSpec, view: View) -> int:
    start = cur.pos
    if cur.peek_digit():
        value = cur.integer()
    elif spec.optional:
        return spec.default
    else:
        reason = f"a number expected: {spec.doc}"
        raise rejection_at(cur.text, start, "index", reason, "§6", (spec.doc,), spec.name)
    high = spec.hi(view.identity.limits)
    if not spec.lo <= value <= high:
        reason = f"{value} is out of range: {spec.name} {spec.lo}..{high}"
        raise rejection_at(cur.text, start, "index", reason, "§6", (f"{spec.lo}..{high}",))
    return value


def _channels(cur: Cursor, spec: IndexSpec, view: View) -> list[int] | None:
    start = cur.pos
    try:
        channels = cur.channel_list()
    except ParseError:
        reason = "a channel list is `1 3 4` or `010304` (two digits per channel)"
        raise rejection_at(
            cur.text, start, "channels", reason, "§6.5", ("1 3 4", "010304")
        ) from None
    if channels is not None:
        high = spec.hi(view.identity.limits)
        for c in channels:
            if not 1 <= c <= high:
                reason = f"channel {c}: this logger has channels 1..{high}"
                at = start
                for word in cur.text[start : cur.pos].split(" "):
                    if word == str(c):
                        break
                    at += len(word) + 1
                else:
                    at = start
                raise rejection_at(cur.text, at, "channels", reason, "§6.5", (f"1..{high}",))
    return channels


def _no_leaf(cur: Cursor, begin: int, node: Node, switch: str) -> Refused:
    """The words read are not a parameter for this switch (built on refusal only)."""
    start = cur.pos
    while start < len(cur.text) and cur.text[start] == " ":
        start += 1
    name = " ".join(cur.text[begin:start].lower().split())
    dead_end = not node.words and node.index is None
    if dead_end or (("W" if switch == "R" else "R") in node.leaves and cur.at_end()):
        reason = f"`{name}` cannot be {'read' if switch == 'R' else 'written'}"
        return rejection_at(cur.text, start, "keyword", reason, "§6", (), name)
    options = sorted(node.words)
    if node.index is not None:
        options.append(f"<{node.index[0].doc}>")
    reason = _keyword_reason(name, options)
    return rejection_at(cur.text, start, "keyword", reason, "§6", tuple(options), name)


def _keyword_reason(name: str, options: list[str] | tuple[str, ...]) -> str:
    reason = f"after `{name}`" if name else "a parameter name"
    return reason + (f": expected one of {', '.join(options)}" if options else ": nothing more")


def _modifiers(cur: Cursor, command: Command) -> None:
    leaf = command.leaf
    while True:
        if leaf.dual and not command.all_inputs and cur.try_keyword(("all",)):
            command.all_inputs = True
        elif leaf.hexable and not command.hexadecimal and cur.try_keyword(("x",)):
            command.hexadecimal = True
        else:
            return


def _values(cur: Cursor, command: Command, view: View) -> None:
    multi = len(command.targets) > 1
    vtype = command.leaf.vtype
    if command.leaf.group_writer is not None:
        value = vtype.parse(cur, ParseCtx(view, command.targets[0], multi))
        command.values.append([value] if value else [])
        return
    for indices in command.targets:
        ctx = ParseCtx(view, indices, multi)
        slots = 2 if command.all_inputs else 1
        values: list[str] = []
        for slot in range(slots):
            if slot:
                cur.skip_spaces()
                if cur.pos < len(cur.text) and cur.text[cur.pos] == ",":
                    cur.pos += 1
            if command.hexadecimal and isinstance(vtype, ChannelAddress):
                values.append(vtype.parse_hex(cur, ctx))
            else:
                values.append(vtype.parse(cur, ctx))
        command.values.append(values)


@dataclass(frozen=True)
class Parsed:
    """:func:`parse_line`'s result: the commands parsed, and the rejection if refused."""

    commands: tuple[Command, ...]
    ends: tuple[int, ...]  # where each command ends in the line
    rejection: Rejection | None


_HEADER_OR_SWITCH = (*HEADER_WORDS, *_SWITCH_WORDS)


def parse_line(text: str, view: View) -> Parsed:
    """Parse a whole line as the interpreter does, without running it; named commands
    (§6.8) are not expanded. The values of ``view`` decide the limits (channel count)."""
    cur = Cursor(text)
    commands: list[Command] = []
    ends: list[int] = []
    try:
        switch = _headers(cur)
        node, first = ROOT, None
        while True:
            start = cur.pos
            try:
                command, first_word = parse_command(cur, switch, node, view)
            except Refused as exc:
                found = exc.rejection
                if first is None or found.what != "keyword":
                    raise
                if found.subject and not found.expected:
                    raise
                if found.subject:  # §7.2: name the first keyword carried over
                    name = f"{first} {found.subject}"
                    reason = _keyword_reason(name, found.expected)
                    raise Refused(replace(found, subject=name, reason=reason)) from None
                reason = (
                    "after a complete command the line ends, or goes on with read/write (§7.1)"
                    f" or with another `{first} ...` parameter (§7.2)"
                )
                expected = ("read", "write", f"{first} ...")
                raise rejection_at(text, start, "chain", reason, "§7", expected, first) from None
            except Unavailable as exc:
                raise rejection_at(text, start, "unavailable", str(exc), "§6") from None
            first = first or first_word
            commands.append(command)
            ends.append(cur.pos)
            if cur.at_end():
                return Parsed(tuple(commands), tuple(ends), None)
            if command.leaf.ends_line:
                pattern = command.leaf.pattern
                reason = f"nothing may follow `write {pattern}` on its line (§7)"
                raise rejection_at(text, cur.pos, "end", reason, "§7", (), pattern)
            new_switch = parse_switch(cur)
            if new_switch is not None:
                switch, node, first = new_switch, ROOT, None  # §7.1
            else:
                assert first is not None
                node = ROOT.words[first]  # §7.2: the switch and first keyword carry over
    except Refused as exc:
        return Parsed(tuple(commands), tuple(ends), exc.rejection)


def _headers(cur: Cursor) -> str:
    """The header keywords (§8.2) up to the switch; returns the switch."""
    headers = Headers()
    while True:
        cur.skip_spaces()
        start = cur.pos
        word = cur.choose_word(_HEADER_OR_SWITCH)
        if word is None:
            if cur.at_end():
                reason = "read or write expected after the header keywords"
                raise rejection_at(cur.text, start, "switch", reason, "§5", _SWITCH_WORDS)
            reason = "header keyword, read, write or a command name expected"
            raise rejection_at(cur.text, start, "header", reason, "§8.2", _HEADER_OR_SWITCH)
        if word in _SWITCH_WORDS:
            return "R" if word == "read" else "W"
        try:
            headers.parse_one(word, cur)
        except ParseError as exc:
            raise rejection_at(cur.text, cur.pos, "header", str(exc), "§8", (), word) from None
