"""AT command lines (ITU-T V.250 §5, 3GPP TS 27.007 §4): parsing and result codes.

A command line starts with ``AT`` (any case) and holds basic commands (``E0``, ``V1``, ``H``,
``S0=2``, ``&F``, ``D<number>``) and extended ones (``+CMGF=1``, ``+CSQ``, ``+CREG?``,
``+CSCS=?``) separated by ``;`` after an extended command. ``D`` takes the rest of the line.
"""

from __future__ import annotations

from dataclasses import dataclass

SET = "="
READ = "?"
TEST = "=?"
EXEC = ""


class AtSyntaxError(ValueError):
    """A command line that cannot be parsed: the modem answers ``ERROR``."""


class CmeError(Exception):
    """Ends a command with ``+CME ERROR: <code>`` (``ERROR`` under ``AT+CMEE=0``)."""

    def __init__(self, code: int) -> None:
        super().__init__(code)
        self.code = code


class CmsError(CmeError):
    """Ends an SMS command with ``+CMS ERROR: <code>``."""


#: :class:`Finish` with this: the line ends without a final result code (``AT+CPIN?``).
NO_FINAL = ""


class Finish(Exception):
    """Ends the command line with ``final`` (``None``: the answer comes later;
    :data:`NO_FINAL`: there is none)."""

    def __init__(self, final: str | None, lines: tuple[str, ...] = ()) -> None:
        super().__init__(final)
        self.final = final
        self.lines = lines


@dataclass(frozen=True, slots=True)
class AtCommand:
    """One command of a line: ``name`` upper case (``E``, ``&F``, ``+CMGS``), ``kind`` one of
    :data:`SET`, :data:`READ`, :data:`TEST`, :data:`EXEC`, ``args`` the text after ``=``
    (for a basic command: its number, for ``D``: the dial string)."""

    name: str
    kind: str = EXEC
    args: str = ""

    def params(self) -> list[str]:
        """Comma-separated arguments with surrounding quotes removed."""
        return [p.strip().strip('"') for p in split_params(self.args)] if self.args else []

    def ints(self, minimum: int = 0, maximum: int | None = None) -> list[int | None]:
        """Arguments as integers (``None`` where omitted); raises :class:`AtSyntaxError`."""
        out: list[int | None] = []
        for p in split_params(self.args) if self.args else []:
            p = p.strip()
            if p == "":
                out.append(None)
                continue
            if not p.isdigit():
                raise AtSyntaxError(f"not a number: {p!r}")
            out.append(int(p))
        if len(out) < minimum:
            raise AtSyntaxError("too few parameters")
        if maximum is not None and len(out) > maximum:
            raise AtSyntaxError("too many parameters")
        return out


def split_params(text: str) -> list[str]:
    """Split on commas outside double quotes; an unclosed quote is a syntax error."""
    parts: list[str] = []
    current: list[str] = []
    quoted = False
    for ch in text:
        if ch == '"':
            quoted = not quoted
        if ch == "," and not quoted:
            parts.append("".join(current))
            current = []
        else:
            current.append(ch)
    if quoted:
        raise AtSyntaxError("unclosed quote")
    parts.append("".join(current))
    return parts


_EXTENDED_PREFIXES = "+$%*^#"


def parse_line(line: str) -> list[AtCommand] | None:
    """Commands of one line, or ``None`` when it is not an AT command line (no ``AT``
    prefix: ignored, as a modem ignores noise). Raises :class:`AtSyntaxError`."""
    text = line.strip()
    start = text.upper().find("AT")
    if start < 0:
        return None
    body = text[start + 2 :]
    commands: list[AtCommand] = []
    i = 0
    n = len(body)
    while i < n:
        ch = body[i]
        if ch in " ;":
            i += 1
            continue
        if ch in _EXTENDED_PREFIXES:
            j = i + 1
            while j < n and (body[j].isalnum() or body[j] in "_."):
                j += 1
            name = body[i:j].upper()
            if len(name) < 2:
                raise AtSyntaxError(f"bad extended command at {body[i:]!r}")
            end = _end_of_extended(body, j)
            commands.append(_extended(name, body[j:end]))
            i = end + 1
            continue
        upper = ch.upper()
        if upper == "D":
            commands.append(AtCommand("D", SET, body[i + 1 :].strip()))
            break
        if upper == "&":
            if i + 1 >= n or not body[i + 1].isalpha():
                raise AtSyntaxError("bad & command")
            name = "&" + body[i + 1].upper()
            i += 2
        elif upper.isalpha():
            name = upper
            i += 1
        else:
            raise AtSyntaxError(f"unexpected {ch!r}")
        if name == "S":
            j = i
            while j < n and body[j].isdigit():
                j += 1
            if j == i:
                raise AtSyntaxError("S without register number")
            reg = body[i:j]
            if j < n and body[j] == "?":
                commands.append(AtCommand("S" + reg, READ))
                i = j + 1
                continue
            if j < n and body[j] == "=":
                k = j + 1
                while k < n and body[k].isdigit():
                    k += 1
                commands.append(AtCommand("S" + reg, SET, body[j + 1 : k]))
                i = k
                continue
            raise AtSyntaxError("S register without = or ?")
        j = i
        while j < n and body[j].isdigit():
            j += 1
        commands.append(AtCommand(name, EXEC, body[i:j]))
        i = j
    return commands


def _end_of_extended(body: str, j: int) -> int:
    quoted = False
    k = j
    while k < len(body):
        if body[k] == '"':
            quoted = not quoted
        elif body[k] == ";" and not quoted:
            return k
        k += 1
    if quoted:
        raise AtSyntaxError("unclosed quote")
    return k


def _extended(name: str, rest: str) -> AtCommand:
    rest = rest.strip()
    if rest == "":
        return AtCommand(name, EXEC)
    if rest == "?":
        return AtCommand(name, READ)
    if rest == "=?":
        return AtCommand(name, TEST)
    if rest.startswith("="):
        return AtCommand(name, SET, rest[1:])
    raise AtSyntaxError(f"bad {name} syntax: {rest!r}")


#: ATV0 numeric result codes (V.250 §5.7.1 table 1).
NUMERIC = {
    "OK": "0",
    "CONNECT": "1",
    "RING": "2",
    "NO CARRIER": "3",
    "ERROR": "4",
    "NO DIALTONE": "6",
    "BUSY": "7",
    "NO ANSWER": "8",
}


def format_info(text: str, verbose: bool) -> bytes:
    """An information response line."""
    return (f"\r\n{text}\r\n" if verbose else f"{text}\r\n").encode("latin-1", "replace")


def format_result(code: str, verbose: bool) -> bytes:
    """A final or unsolicited result code (``ATV1``: ``<CR><LF>OK<CR><LF>``; ``ATV0``:
    ``0<CR>``; codes without a number stay text)."""
    if verbose:
        return f"\r\n{code}\r\n".encode("latin-1", "replace")
    key = "CONNECT" if code.startswith("CONNECT") else code
    number = NUMERIC.get(key)
    return f"{number}\r".encode() if number else f"{code}\r\n".encode("latin-1", "replace")
