"""The body of a command line, parsed without running it (§5, §6, §7): the switch, the
keywords down the parameter trie, indices and channel lists, modifiers (``all``, ``x``) and
values. Pure: a host tool can run it to explain why a line was refused."""

from __future__ import annotations

from dataclasses import dataclass, field

from sondalog.ala1.headers import Headers
from sondalog.ala1.model import Unavailable, View
from sondalog.ala1.params import ROOT, IndexSpec, Leaf, Node
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
        raise ParseError("no such parameter for this switch")
    if "{ch}" in leaf.pattern:
        if channels is None:
            channels = list(range(1, int(view.get("channel max number")) + 1))
        targets = [{**indices, "ch": c} for c in channels]
    else:
        targets = [indices]
    command = Command(switch, leaf, targets)
    _modifiers(cur, command)
    if switch == "R":
        if leaf.read_arg is not None:
            command.arg = leaf.read_arg.parse(cur, ParseCtx(view, indices))
    else:
        _values(cur, command, view)
    if leaf.unavailable:
        raise Unavailable(leaf.unavailable)
    return command, first_word


def _index(cur: Cursor, spec: IndexSpec, view: View) -> int:
    if cur.peek_digit():
        value = cur.integer()
    elif spec.optional:
        return spec.default
    else:
        raise ParseError(f"{spec.doc} expected")
    if not spec.lo <= value <= spec.hi(view.identity.limits):
        raise ParseError(f"{spec.doc}: {value} out of range")
    return value


def _channels(cur: Cursor, spec: IndexSpec, view: View) -> list[int] | None:
    channels = cur.channel_list()
    if channels is not None:
        high = spec.hi(view.identity.limits)
        if any(not 1 <= c <= high for c in channels):
            raise ParseError("channel number out of range")
    return channels


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
