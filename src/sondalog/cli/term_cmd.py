"""``sondalog term URL``: a terminal to an ALA1 logger (parsing and printing only; the work is
in :mod:`sondalog.client`).

Interactive (stdin is a terminal): line editing and history (prompt_toolkit); every line typed
is sent with CR, and everything the logger sends is printed as it arrives, including answers
that come later (``pause``, §8.5.1) and echo (``+``, §3.4.2). Ctrl-C clears the line being
typed; Ctrl-D quits.

Scripted (stdin is not a terminal): each stdin line is sent as one command and its answer is
printed once it is complete: a final ``OK`` (plain or decorated, ``00154,OK``) or ``ERROR``
line. The ``--timeout`` runs from the last byte received, so a long answer on a slow line is
never cut; a line with a ``quiet`` header (§8.5.3), which has no final line, ends after a
short silence. A command the logger refused (its answer ends with ``ERROR``, §3.3.1), a
command with no answer (a failed ``check``), or an answer that stops without its final line
(the line died), is reported on stderr and makes the exit status 1 (``--ignore-errors``: not
for ``ERROR``); a line the logger cannot receive (a character outside ASCII) is not sent, is
reported, and makes it 2. When nothing at all came back, ``term`` asks whether the peer is an
HCTMPS1 bus (one ``HELLO`` broadcast) and names the command for it.

Both modes know local commands, lines starting with ``:`` that are not sent: ``:help``,
``:log FILE``, ``:explain [LINE]``, ``:quit`` (see :data:`sondalog.app.explain.HELP`).
Example::

    printf 'read i version\\n' | sondalog term tcp://127.0.0.1:10001
    printf 'read i version\\n' | sondalog term "serial:///tmp/ala1?baud=9600"
"""

from __future__ import annotations

import asyncio
import contextlib
import sys
from pathlib import Path
from typing import TextIO

import click

from sondalog.app.explain import HELP, explain, header_words, unsendable
from sondalog.client import (
    Ala1Client,
    ClientError,
    Endpoint,
    parse_url,
)
from sondalog.client.ala1_codec import ConnectionLost, ends_final
from sondalog.client.trace import TracedEndpoint, TraceWriter


def _text(data: bytes) -> str:
    """Received bytes for a text terminal: CR LF becomes a newline."""
    return data.decode("latin-1").replace("\r\n", "\n")


class _Local:
    """What the local commands (``:help``, ``:log``, ``:explain``) need across lines."""

    def __init__(self) -> None:
        self.log: TextIO | None = None
        self.refused: str | None = None
        """The last line the logger refused, as it echoed it (§3.3.1)."""
        self.quit = False
        self._tail = ""
        self.heard = False
        """Did the peer send anything at all this session?"""
        self.unanswered = 0
        """Lines that should have been answered (no ``check``, no ``quiet``) and were not."""

    def sent(self, line: str) -> None:
        if self.log is not None:
            self.log.write(f"> {line}\n")
            self.log.flush()

    def received(self, text: str) -> None:
        """Text from the logger: log it and remember the line an ``ERROR`` refers to."""
        if self.log is not None:
            self.log.write(text)
            self.log.flush()
        self.heard = self.heard or bool(text)
        lines = (self._tail + text).split("\n")
        self._tail = lines.pop()
        for before, line in zip(["", *lines], lines, strict=False):
            if line.rstrip("\r") == "ERROR" and before:
                self.refused = before.rstrip("\r")

    def run(self, line: str) -> tuple[str, int]:
        """Run local command ``line`` (``:name args``): its output and an exit status."""
        name, _, arg = line[1:].strip().partition(" ")
        arg = arg.strip()
        if name in ("help", "h", "?"):
            return HELP, 0
        if name in ("quit", "q", "exit"):
            self.quit = True
            return "", 0
        if name == "log":
            return self._set_log(arg)
        if name == "explain":
            target = arg or self.refused
            if not target:
                return (
                    "nothing to explain yet: no line was refused (or give one: :explain LINE)\n",
                    0,
                )
            return explain(target).render() + "\n", 0
        return f"unknown local command {line!r}; :help lists them\n", 2

    def _set_log(self, arg: str) -> tuple[str, int]:
        if self.log is not None:
            self.log.close()
            self.log = None
            if not arg:
                return "log closed\n", 0
        if not arg:
            return "no log is open (:log FILE starts one)\n", 0
        try:
            self.log = Path(arg).expanduser().open("a", encoding="latin-1", newline="\n")
        except OSError as exc:
            return f"cannot log to {arg}: {exc.strerror or exc}\n", 2
        return f"logging the session to {arg}\n", 0

    def close(self) -> None:
        if self.log is not None:
            self.log.close()
            self.log = None


@click.command()
@click.argument("url")
@click.option(
    "--timeout",
    type=click.FloatRange(min=0, min_open=True),
    default=2.0,
    show_default=True,
    help="Seconds of silence after which an answer read from stdin counts as ended.",
)
@click.option(
    "--ignore-errors",
    is_flag=True,
    help="Reading from stdin, exit 0 even when the logger answered ERROR to a line.",
)
@click.option(
    "--trace",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Record the session's bytes both ways in this file, for 'logger replay' "
    "(docs/testing.md).",
)
def term(url: str, timeout: float, ignore_errors: bool, trace: Path | None) -> None:
    """Talk to an ALA1 logger at URL (tcp://HOST:PORT, serial:///DEVICE?baud=9600).

    A serial URL also opens the pty of "logger serve --pty PATH": serial://PATH?baud=9600.
    gsm://API-HOST:PORT/NUMBER?from=PHONE places a data call to a modem of a served GSM
    network and talks through it once the modem answered (docs/gsm.md).
    Lines starting with ":" are local commands (:help, :log FILE, :explain, :quit).
    --trace FILE records the line (docs/testing.md), which "sondalog logger replay FILE"
    serves back.

    Reading commands from stdin, exit status 1 means the logger answered ERROR to a
    line, or a line got no answer or an incomplete one (reported on stderr), 2 that a
    line could not be sent.
    """
    try:
        endpoint = parse_url(url)
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="URL") from exc
    writer: TraceWriter | None = None
    if trace is not None:
        try:
            writer = TraceWriter(trace, str(endpoint))
        except OSError as exc:
            raise click.BadParameter(
                f"cannot write {trace}: {exc.strerror or exc}", param_hint="--trace"
            ) from exc
        endpoint = TracedEndpoint(endpoint, writer)
    try:
        status = asyncio.run(_session(url, endpoint, timeout, sys.stdin, not ignore_errors))
    except OSError as exc:
        raise click.ClickException(f"cannot connect to {endpoint}: {exc}") from exc
    finally:
        if writer is not None:
            writer.close()
    sys.exit(status)


async def _session(
    url: str, endpoint: Endpoint, timeout: float, stdin: TextIO, errors_fail: bool
) -> int:
    client = await Ala1Client.connect(endpoint, timeout)
    local = _Local()
    try:
        if stdin.isatty():
            return await _interactive(client, local, url, timeout)
        status = await _scripted(client, stdin, timeout, local, errors_fail)
    finally:
        local.close()
    if local.unanswered and not local.heard:
        click.echo(await _silent_peer(url), err=True)
    return status


async def _silent_peer(url: str) -> str:
    """What to say when ``url`` answered nothing at all: an ALA1 logger answers every line, so
    it may be an HCTMPS1 bus (the reverse of ``bus scan`` at a logger): one ``HELLO``
    broadcast (hctmps1.md §2) tells; three rounds, since two modules that pick the same reply
    slot collide and neither is heard in that round."""
    from sondalog.client.bus import BusMaster
    from sondalog.client.bus_errors import BusError

    heard: set[str] = set()
    with contextlib.suppress(ValueError, OSError, BusError):
        master = await BusMaster.open(url)
        try:
            for _ in range(HELLO_ROUNDS):
                heard |= {frame.src for frame in await master.broadcast("HELLO")}
        finally:
            await master.close()
    modules = sorted(heard)
    if modules:
        return (
            f"{url} is an HCTMPS1 bus, not an ALA1 logger: {_modules(modules)} answered "
            f"HELLO. Talk to it with: sondalog bus scan {url}"
        )
    return _SILENT.format(url=url)


def _modules(ids: list[str]) -> str:
    return f"module {ids[0]}" if len(ids) == 1 else f"modules {', '.join(ids)}"


#: HELLO broadcasts asked of a silent peer (replies in random slots can collide).
HELLO_ROUNDS = 3

#: The hint when a peer stays silent (interactive mode, or no bus module answered HELLO).
_SILENT = (
    "nothing at all came back from {url}: an ALA1 logger answers every line (OK or ERROR). "
    "Check the address, cable and baud rate; an HCTMPS1 bus? Try: sondalog bus scan {url}"
)


def _expects_answer(line: str) -> bool:
    """Must a logger answer ``line``? Not with ``check`` (silent when the sum is wrong) or
    ``quiet`` (no final line, §8.5.3), nor an empty line."""
    return bool(line.strip(" ")) and not header_words(line) & {"check", "quiet"}


def _refused(answer: bytes) -> bool:
    """Does a complete ``answer`` end with the error response (``ERROR``, plain or decorated
    by ``sum``, ``number``, ``endline``; §3.3.1)?"""
    last = answer.rstrip(b"\r\n").rsplit(b"\n", 1)[-1]
    return b"ERROR" in last and b"OK" not in last


def _incomplete(line: str, answer: bytes, timeout: float) -> str | None:
    """Why ``answer`` is not a whole answer to ``line``, or None when it is."""
    if ends_final(answer):
        return None
    last = answer.rstrip(b"\r\n").rsplit(b"\n", 1)[-1]
    headers = header_words(line)
    if "quiet" in headers:
        return None  # §8.5.3: no final line to wait for
    if headers & {"startline", "endline"} and (b"OK" in last or b"ERROR" in last):
        return None  # a decorated final line
    lines = answer.count(b"\n")
    return (
        f"incomplete answer to {line!r}: {lines} lines ({len(answer)} bytes) and no final OK"
        f" or ERROR; nothing more came for {timeout:g} s (--timeout)"
    )


async def _scripted(
    client: Ala1Client, stdin: TextIO, timeout: float, local: _Local, errors_fail: bool = True
) -> int:
    status = 0
    try:
        for raw_line in stdin:
            line = raw_line.rstrip("\r\n")
            if not line.strip(" "):
                continue  # the logger ignores empty lines: nothing to wait for
            if line.startswith(":"):
                output, code = local.run(line)
                click.echo(output, nl=False)
                status = max(status, code)
                if local.quit:
                    break
                continue
            problem = unsendable(line)
            if problem is not None:
                click.echo(f"not sent: {line!r}: {problem}", err=True)
                status = 2
                continue
            quiet = "quiet" in header_words(line)
            local.sent(line)
            answer = await client.exchange_raw(
                line, timeout=timeout, quiet_period=None if quiet else timeout
            )
            text = _text(answer)
            click.echo(text, nl=False)
            local.received(text)
            if not answer:
                click.echo(f"no answer to {line!r}", err=True)
                status = max(status, 1)
                if _expects_answer(line):
                    local.unanswered += 1
            elif (why := _incomplete(line, answer, timeout)) is not None:
                if not text.endswith("\n"):
                    click.echo("")
                click.echo(why, err=True)
                status = max(status, 1)
            elif errors_fail and _refused(answer):
                click.echo(f"the logger answered ERROR to {line!r} (:explain tells why)", err=True)
                status = max(status, 1)
    except ConnectionLost as exc:
        click.echo(f"connection lost: {exc}", err=True)
        status = max(status, 1)
    finally:
        await client.close()
    return status


async def _interactive(client: Ala1Client, local: _Local, url: str, timeout: float) -> int:
    from prompt_toolkit import PromptSession
    from prompt_toolkit.history import InMemoryHistory
    from prompt_toolkit.patch_stdout import patch_stdout

    session: PromptSession[str] = PromptSession(history=InMemoryHistory())
    closed = asyncio.Event()
    hinted: list[bool] = []  # the :explain hint is shown once a session
    silence: list[asyncio.Task[None]] = []  # the silent-peer hint: once a session

    async def hint_if_silent() -> None:
        await asyncio.sleep(timeout)
        if not local.heard:
            print(f"({_SILENT.format(url=url)})", flush=True)

    async def show_incoming() -> None:
        try:
            while True:
                data = await client.receive_raw(3600.0)
                if data:
                    text = _text(data)
                    refused = local.refused
                    local.received(text)
                    print(text, end="", flush=True)
                    if local.refused != refused and not hinted:
                        print("(:explain tells which part the logger refused)", flush=True)
                        hinted.append(True)
        except ClientError:
            print("connection closed by the logger", flush=True)
            closed.set()

    print("connected; :help lists the local commands, Ctrl-D quits", flush=True)
    with patch_stdout():
        reader = asyncio.create_task(show_incoming())
        try:
            while not closed.is_set() and not local.quit:
                try:
                    line = await session.prompt_async("ala1> ")
                except KeyboardInterrupt:
                    continue
                except EOFError:
                    break
                if line.startswith(":"):
                    print(local.run(line)[0], end="", flush=True)
                    continue
                problem = unsendable(line)
                if problem is not None:
                    print(f"not sent: {problem}", flush=True)
                    continue
                if not closed.is_set():
                    local.sent(line)
                    await client.send_raw(line.encode("ascii") + b"\r")
                    if not local.heard and not silence and _expects_answer(line):
                        silence.append(asyncio.create_task(hint_if_silent()))
        finally:
            for task in (*silence, reader):
                task.cancel()
            for task in silence:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            with contextlib.suppress(asyncio.CancelledError):
                await reader
            await client.close()
    return 1 if closed.is_set() else 0
