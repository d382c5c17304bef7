"""Command lines: header (§8), switch and body (§5, §6), chaining (§7), named commands (§6.8).

:func:`Interpreter.run_line` takes one complete line (after line editing) and returns the
bytes of the answer, or None when the module stays silent (a failed ``check``, a foreign
``iaddress``). It never performs I/O beyond the injected non-volatile store.
"""

from __future__ import annotations

from dataclasses import dataclass

from sondalog.ala1.headers import HEADER_WORDS, MAX_LINE, Headers
from sondalog.ala1.model import CommandError, Unavailable, View
from sondalog.ala1.params import ROOT
from sondalog.ala1.parser import Command, Plan, parse_command, parse_switch
from sondalog.ala1.special import TransferRequest, request
from sondalog.ala1.state import ModuleState, NeedWait, Transaction
from sondalog.ala1.tokens import Cursor, ParseError, format_stamp
from sondalog.ala1.values import Indices
from sondalog.protocol.cksum import cksum

#: Keyword sets matched on every line (one-word keywords: :meth:`Cursor.choose_word`).
_SWITCH_WORDS = ("read", "write")
_HEADER_OR_SWITCH = (*HEADER_WORDS, *_SWITCH_WORDS)
_OK = b"OK\r\n"
#: The most parsed lines kept (:class:`Plan`).
MAX_PLANS = 256


@dataclass
class Answer:
    """The bytes of one answer and the rate to send them at (``comspeed``, §8.5.2)."""

    data: bytes
    baud: int | None = None
    release: bool = False  # the line ran `write com close` (§6.11.8)
    transfer: TransferRequest | None = None  # an XMODEM transfer follows (§6.16)


class Interpreter:
    """Runs complete command lines against a :class:`ModuleState`."""

    def __init__(self, state: ModuleState) -> None:
        self.state = state
        self._commands = 0

    # -- entry points ------------------------------------------------------------------------
    def run_line(
        self,
        line: str,
        host_now: float,
        *,
        overflow: bool = False,
        paused: bool = False,
    ) -> Answer | None:
        """Execute one command line; None means the module stays silent.

        Raises :class:`NeedWait` for a ``pause`` header (§8.5.1; unless ``paused``: the pause
        is over) or when a measurement must wait for a switch or a conversion; nothing has
        run then, and the caller runs the line again after the wait.

        ``overflow``: the line had more than 120 characters; the extra ones were dropped and
        the answer is the error response for the first 120 (spec notes §1).
        """
        plan = None if overflow else self.state.plans.get(line)
        if plan is not None:
            return self._run_plan(line, plan, host_now, paused)
        too_long = overflow or len(line) > MAX_LINE
        line = line[:MAX_LINE]
        cur = Cursor(line)
        headers = Headers()
        named: str | None = None
        failed = too_long
        try:
            named = self._headers(cur, headers)
        except ParseError:
            failed = True
        if not headers.check_ok():
            return None
        own = self.state.setting("i address")
        if own and named is None and headers.iaddress != own:
            return None
        if failed:
            return self._error(line, headers)
        return self._run(line, cur, headers, named, host_now, paused, None, keep=True)

    def run_stored(
        self,
        number: int,
        host_now: float,
        *,
        paused: bool = False,
        deferred: dict[str, str] | None = None,
    ) -> Answer | None:
        """§6.8.4, §6.14.3: command ``number`` run for a message, as if invoked by name
        (§6.8.5: no ``iaddress`` needed; a final ``&`` appends nothing). ``deferred``
        collects the last-read points a ``shift`` would move (§6.8.4.1): they are not
        committed with the line."""
        value = self.state.get(f"command {number} value")
        line = value[:-1] if value.endswith("&") else value
        if not line.strip(" "):
            return None  # like an empty line: no answer
        cur = Cursor(line)
        headers = Headers()
        try:
            if self._headers(cur, headers) is not None:
                raise ParseError("a named command cannot run another one")
        except ParseError:
            return self._error(line, headers)
        if not headers.check_ok():
            return None
        return self._run(line, cur, headers, None, host_now, paused, deferred)

    def _run(
        self,
        line: str,
        cur: Cursor,
        headers: Headers,
        named: str | None,
        host_now: float,
        paused: bool,
        deferred: dict[str, str] | None,
        *,
        keep: bool = False,
    ) -> Answer | None:
        """``keep``: a line received (not a stored command) may keep its parse (:class:`Plan`)."""
        if headers.pause and not paused:
            raise NeedWait(headers.pause, line_time=True)
        txn = self.state.begin(host_now)
        txn.deferred = deferred
        commands: list[Command] = []
        try:
            if named is not None:
                cur = self._expand(named, cur, headers, txn)
            lines = self._body(cur, txn, commands)
        except (ParseError, CommandError, Unavailable, ValueError):
            txn.rollback()
            return self._error(line, headers)
        except BaseException:
            txn.rollback()
            raise
        answer = self._finish(line, headers, txn, lines)
        if (
            keep
            and named is None
            and all(command.switch == "R" for command in commands)
            and (len(commands) == 1 or not txn.changes)
        ):
            # Every command was parsed against the committed values: the parse holds
            # until they change. (A later command of a line can see an earlier one's
            # moved read point: such lines are parsed again.) When every command reads
            # what only a committed change can change, so does the answer.
            plans = self.state.plans
            if len(plans) >= MAX_PLANS:
                plans.clear()  # a client sending ever new lines does not grow the memory
            constant = (
                headers.counter is None
                and not headers.date
                and all(command.leaf.constant_read for command in commands)
            )
            data = answer.data if answer is not None and constant else None
            plans[line] = Plan(headers, tuple(commands), data)
        return answer

    def _run_plan(self, line: str, plan: Plan, host_now: float, paused: bool) -> Answer | None:
        """:meth:`_run` for a line parsed before (issue 11): only the commands run."""
        headers = plan.headers
        if headers.pause and not paused:
            raise NeedWait(headers.pause, line_time=True)
        if plan.answer is not None:
            return Answer(plan.answer, headers.comspeed)
        txn = self.state.begin(host_now)
        lines: list[str] = []
        self._commands = len(plan.commands)
        try:
            for command in plan.commands:
                lines.extend(self._execute(command, txn))
        except (ParseError, CommandError, Unavailable, ValueError):
            txn.rollback()
            return self._error(line, headers)
        except BaseException:
            txn.rollback()
            raise
        return self._finish(line, headers, txn, lines)

    def _finish(
        self, line: str, headers: Headers, txn: Transaction, lines: list[str]
    ) -> Answer | None:
        """The end of a line that ran: wait, transfer, or commit and answer."""
        if txn.waits:
            txn.rollback()
            raise NeedWait(max(txn.waits))
        if txn.transfer is not None:
            if self._commands != 1:  # decision: a transfer command stands alone on its line
                txn.rollback()
                return self._error(line, headers)
            txn.commit()
            area, reading = txn.transfer
            return Answer(b"", headers.comspeed, transfer=request(self.state, area, reading))
        txn.commit()
        return Answer(self._render(lines, headers, txn), headers.comspeed, txn.released)

    # -- header and named commands -----------------------------------------------------------
    def _headers(self, cur: Cursor, headers: Headers) -> str | None:
        """Parse header keywords up to the switch; return a named command's text if any."""
        while True:
            cur.skip_spaces()
            start = cur.pos
            name = self._named_at(cur.rest())
            word = cur.choose_word(_HEADER_OR_SWITCH)
            if name is not None and (word is None or len(name) > cur.pos - start):
                cur.pos = start
                return name
            if word is None:
                raise ParseError("header keyword, read, write or a command name expected")
            if word in ("read", "write"):
                cur.pos = start
                return None
            headers.parse_one(word, cur)

    def _named_at(self, text: str) -> str | None:
        """The longest command name that prefixes ``text`` (case-sensitive, §6.8.2)."""
        best: str | None = None
        for name in self.state.command_names():
            if text.startswith(name) and (best is None or len(name) > len(best)):
                best = name
        return best

    def _expand(self, name: str, cur: Cursor, headers: Headers, view: View) -> Cursor:
        """§6.8.3: the command's value, with ``&`` replaced by the text after the name."""
        tail = cur.rest()[len(name) :]
        value = view.get(f"command {self.state.command_names()[name]} value")
        if value.endswith("&"):
            value = value[:-1] + tail
        inner = Cursor(value)
        if self._headers(inner, headers) is not None:
            raise ParseError("a named command cannot run another one")
        if not headers.check_ok():
            raise ParseError("check of a named command's value failed")
        return inner

    # -- body ------------------------------------------------------------------------------
    def _body(self, cur: Cursor, view: Transaction, commands: list[Command]) -> list[str]:
        """§5, §7: run every command of the body, chained, and collect the data lines;
        ``commands`` collects the parsed commands."""
        lines: list[str] = []
        self._commands = 0
        switch = parse_switch(cur)
        if switch is None:
            raise ParseError("read or write expected")
        first: str | None = None
        node = ROOT
        while True:
            start = cur.pos
            command, first_word = parse_command(cur, switch, node, view)
            if cur.pos == start:
                raise ParseError("no progress")
            if first is None:
                first = first_word
            self._commands += 1
            commands.append(command)
            lines.extend(self._execute(command, view))
            if cur.at_end():
                return lines
            if command.leaf.ends_line:
                raise ParseError(f"nothing may follow {command.leaf.pattern} (§7)")
            new_switch = parse_switch(cur)
            if new_switch is not None:
                switch, node, first = new_switch, ROOT, None  # §7.1
            else:
                assert first is not None
                node = ROOT.words[first]  # §7.2: the switch and first keyword carry over

    # -- execution ---------------------------------------------------------------------------
    def _execute(self, command: Command, view: View) -> list[str]:
        leaf = command.leaf
        if command.switch == "W":
            if leaf.group_writer is not None:
                leaf.group_writer(view, command.targets, command.values[0])
                return []
            for indices, values in zip(command.targets, command.values, strict=True):
                if leaf.writer is not None:
                    leaf.writer(view, indices, values)
                else:
                    for slot, value in enumerate(values, start=1):
                        view.set(leaf.key(indices, slot), value)
            return []
        if leaf.reader is not None:
            if len(command.targets) == 1:
                return leaf.reader(view, command.targets[0], command.arg)
            if leaf.group_reader is not None:
                return leaf.group_reader(view, command.targets, command.arg)
            return [",".join(",".join(leaf.reader(view, t, command.arg)) for t in command.targets)]
        return [",".join(self._render_value(command, view, t) for t in command.targets)]

    @staticmethod
    def _render_value(command: Command, view: View, indices: Indices) -> str:
        leaf = command.leaf
        slots = (1, 2) if command.all_inputs else (1,)
        parts = []
        for slot in slots:
            stored = view.get(leaf.key(indices, slot))
            if command.hexadecimal:
                parts.append(format(int(stored), "X"))
            else:
                parts.append(leaf.vtype.render(stored, view, indices))
        return ",".join(parts)

    # -- answers ---------------------------------------------------------------------------
    def _render(self, lines: list[str], headers: Headers, view: Transaction) -> bytes:
        """Decorate every line (spec notes §3 order), add crcsum and OK."""
        if not headers.seen:  # no header: the lines as they are (what decorate does then)
            return "".join(f"{line}\r\n" for line in lines).encode("latin-1", "replace") + _OK
        prefix = headers.startline
        if headers.iname:
            prefix += view.get("i name") + ","
        if headers.date:
            prefix += format_stamp(view.now()) + ","
        counters = self.state.counters
        next_number = headers.number

        def decorate(text: str) -> bytes:
            nonlocal next_number
            body = prefix
            if next_number is not None:
                body += f"{next_number},"
                next_number += 1
            elif headers.counter is not None:
                body += f"{counters[headers.counter - 1]},"
                counters[headers.counter - 1] += 1
            body += text + headers.endline
            raw = body.encode("latin-1", "replace")
            if headers.sum:
                raw = b"%05d," % sum(raw) + raw
            return raw + b"\r\n"

        out = [decorate(line) for line in lines]
        if headers.crcsum:
            blob = b"".join(out)
            out.append(decorate(f"{cksum(blob)},{len(blob)}"))
        if not headers.quiet:
            out.append(decorate("OK"))
        return b"".join(out)

    def error_answer(self, line: str) -> Answer:
        """The plain error response (used when something unexpected failed)."""
        return Answer(line[:MAX_LINE].encode("latin-1", "replace") + b"\r\nERROR\r\n")

    @staticmethod
    def _error(line: str, headers: Headers) -> Answer | None:
        """§3.3.1: the line as received, then ERROR; never decorated; ``quiet`` hides it."""
        if headers.quiet:
            return Answer(b"")
        return Answer(line.encode("latin-1", "replace") + b"\r\nERROR\r\n")
