"""The modem driver's core: the AT conversation, presence, idle mode and what to do next.

Bytes from the modem come in with :meth:`ModemDriver.receive` (``now`` given), AT bytes go out
through :meth:`ModemDriver.take_output`; :meth:`ModemDriver.next_deadline` says when to call
:meth:`ModemDriver.advance`. One job runs at a time (:mod:`~sondalog.ala1.modem.jobs`); unsolicited
result codes wait in a queue until the running job has ended. What the driver needs from the
logger (settings, running a command, a command session, the outbox) is a :class:`Host`.

Presence (§6.11.5.2.1, gsm.md §3): the driver sends ``AT``; no answer within 1 s means no
modem and the line works as ``local`` (its bytes go to the command parser). It asks again
every :data:`PROBE_INTERVAL` seconds while the line has been quiet for :data:`PROBE_QUIET`
seconds; when a modem answers, GSM service resumes (the modem is set up again).

Liveness (gsm.md §7; docs/gsm-notes.md §7 says how): until a probe has gone unanswered the
line's bytes are the modem's, never command input; a missed command makes the driver set the
modem up again; the SIM store is listed after every set-up and session; no AT command goes
out in data mode; a reply that fails is kept and tried again (:class:`PendingReply`).
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Generator

from sondalog.ala1.modem import jobs, mailjobs, steps
from sondalog.ala1.modem.atio import (
    MAX_URCS,
    MODEM_OUTPUT,
    At,
    Await,
    CommandMode,
    Job,
    ModemReader,
    PendingReply,
    Recv,
    Reply,
    Request,
    Send,
    Sleep,
    Urc,
    Write,
    is_final,
    is_urc,
)
from sondalog.ala1.modem.credit import GsmReadings
from sondalog.ala1.modem.host import Host
from sondalog.ala1.outbox import Outgoing

log = logging.getLogger(__name__)

#: How often an absent modem is looked for again.
PROBE_INTERVAL = 30.0
#: The line must have been quiet this long before a probe (a person may be typing).
PROBE_QUIET = 5.0
LOCAL = "LOCAL"
#: wavecom42: how often a lost GPRS attachment (and the port 10001 server) is tried again.
GPRS_RETRY = 60.0
_BUSY_URCS = ("+CMTI:", "RING", "+CRING:", "+WIPACCEPT:")
#: A running job: a :data:`Job`, or ``mailjobs.gprs_up`` (its result is not used).
_Running = Generator[Request, object, object]


_PENDING = object()


class ModemDriver:
    """The logger's side of its modem line."""

    def __init__(self, host: Host, now: float) -> None:
        self.host = host
        self.now = now
        self.reader = ModemReader()
        self.readings = GsmReadings()
        self.present: bool | None = None  # None: not asked yet
        self.applied: str | None = None  # the idle mode set up on the modem
        self.radio = True
        self.gprs = False
        self.listening = False
        self.registered_since: float | None = None
        self.session: int | None = None
        #: Replies on their way out, kept until they went (gsm.md §7).
        self.replies: deque[PendingReply] = deque()
        #: The SIM store must be listed: after every set-up and data or GPRS session.
        self.listing_due = False
        self._out = bytearray()
        self._urcs: deque[str] = deque()
        self._job: _Running | None = None
        self._kind = ""
        self._wait: Request | None = None
        self._lines: list[str] = []
        self._deadline: float | None = None
        self._next_probe = now
        self._probed_at = now - PROBE_QUIET
        self.heard = False  # modem output seen on the line while it works as local
        self._recent = b""  # the last bytes of a local line: modem output cut in pieces
        self.resync = False
        self.stray_finals = 0
        self.outstanding = 0  # commands that timed out and whose answer has not come
        self.last_timeout = now
        self._gprs_retry = now

    # -- the line ------------------------------------------------------------------------
    @property
    def device(self) -> str:
        return self.host.setting("com device")

    @property
    def local(self) -> bool:
        """The line works as ``local``: its bytes go to the command parser. Only once a
        probe went unanswered (§6.11.5.2.1): until then they are the modem's."""
        probing = self._job is not None and self._kind == "probe"
        return self.device == LOCAL or (self.present is False and not probing)

    @property
    def busy(self) -> bool:
        """§6.14.9.1: a command session, SMS being read and answered, replies going out."""
        running = self._job is not None and self._kind in ("session", "sms", "reply")
        waiting = any(u.startswith(_BUSY_URCS) for u in self._urcs)
        return running or waiting or self.listing_due or self._reply_due() is not None

    def receive(self, data: bytes, now: float) -> bool:
        """Bytes from the modem; False when the line works as ``local`` (not taken)."""
        self.now = now
        if self.device == LOCAL:
            return False
        if self.local:
            seen = self._recent + data
            if MODEM_OUTPUT.search(seen) is None:
                self._recent = seen[-16:]
                return False
            self._recent = b""  # taken: it must not make later input look like the modem's
            # a modem speaks on a line that works as local: never command input; it is
            # probably back (§6.11.5.2.1): ask soon, however busy the line
            if not self.heard:
                log.info("modem output on the local line: looking for the modem")
                self.heard = True
            self._next_probe = min(self._next_probe, max(now, self._probed_at + PROBE_QUIET))
        for line in self.reader.feed(data):
            self._line(line)
        if self.reader.raw and isinstance(self._wait, Recv) and self.reader.data:
            self._resolve(self.reader.take_data())
        self._schedule()
        return True

    def take_lines(self) -> None:
        """Read the lines waiting in the reader (after data mode ended inside a job)."""
        for line in self.reader.feed(b""):
            self._line(line)

    def advance(self, now: float) -> None:
        self.now = now
        if self._deadline is not None and now >= self._deadline:
            self._timeout()
        self._schedule()

    def next_deadline(self) -> float | None:
        if self._job is not None:
            return self._deadline
        if self.device == LOCAL:
            return None
        if self.present is None:
            return self._next_probe
        if self.present is not True:
            if self.heard:
                return self._next_probe
            return max(self._next_probe, self.host.line_quiet_since() + PROBE_QUIET)
        if self._urcs or self.listing_due or self.applied != self.device or self.reader.raw:
            return self.now
        if self.replies:
            return max(self.now, min(r.next_try for r in self.replies))
        outbox = self.host.outbox
        if outbox.peek("sms") is not None or outbox.peek("email") is not None:
            return self.now  # a sending was put in the outbox: start it
        if self._wants_attach():
            return max(self.now, self._gprs_retry)
        return None

    def take_output(self) -> bytes:
        out = bytes(self._out)
        self._out.clear()
        return out

    def write(self, data: bytes) -> None:
        self._out += data

    def session_output(self, data: bytes) -> None:
        """The answer of a command session's line: to the far end in data mode."""
        if self.session is not None and self.reader.raw:
            self._out += data

    def keep_looking(self) -> None:
        """A modem the driver was talking to stopped answering: probe again soon, however
        busy the line (its traffic may be the modem's, in data mode)."""
        self.heard = True
        self._next_probe = self.now + PROBE_QUIET

    def drop_urcs(self, exact: str) -> None:
        self._urcs = deque(u for u in self._urcs if u != exact)

    def _reply_due(self) -> PendingReply | None:
        return next((r for r in self.replies if r.next_try <= self.now), None)

    def urc(self, prefixes: tuple[str, ...]) -> str | None:
        for line in self._urcs:
            if line.startswith(prefixes):
                self._urcs.remove(line)
                return line
        return None

    # -- running jobs --------------------------------------------------------------------
    def _start(self, kind: str, job: _Running) -> None:
        self._job, self._kind = job, kind
        self._resume(None)

    def _resume(self, value: object) -> None:
        while self._job is not None:
            try:
                request = self._job.send(value)
            except StopIteration:
                self._job, self._wait, self._deadline, self._kind = None, None, None, ""
                return
            except Exception:  # DESIGN.md point 6: a fault in a job never stops the logger
                log.exception("modem job %s failed", self._kind)
                self._job, self._wait, self._deadline, self._kind = None, None, None, ""
                return
            value = self._begin(request)
            if value is not _PENDING:
                continue
            return

    def _begin(self, request: Request) -> object:
        self._wait, self._deadline, self._lines = request, None, []
        if isinstance(request, At | Send):
            if self.present is not True and self._kind != "probe":
                return Reply("")  # the modem went away: every command fails at once
            if self.reader.raw:  # gsm.md §7: no AT command in data mode
                log.warning("modem in data mode: %r not sent", request)
                return Reply("")
        if isinstance(request, At):
            self._out += request.line.encode("latin-1", "replace") + b"\r"
        elif isinstance(request, Send):
            self._out += request.data
        elif isinstance(request, Write):
            self._out += request.data
            return None
        elif isinstance(request, CommandMode):
            self.reader.command_mode()
            return None
        elif isinstance(request, Urc):
            found = self.urc(request.prefixes)
            if found is not None:
                return found
        elif isinstance(request, Recv):
            if self.reader.data:
                return self.reader.take_data()
            if request.until is not None and self.now >= request.until:
                return b""
            self._deadline = request.until
            return _PENDING
        if isinstance(request, Sleep):
            self._deadline = self.now + request.seconds
        else:
            self._deadline = self.now + request.timeout
        return _PENDING

    def _resolve(self, value: object) -> None:
        self._wait, self._deadline = None, None
        self._resume(value)

    def _line(self, line: str) -> None:
        wait = self._wait
        if isinstance(wait, At | Send | Await):
            if line == "> ":
                if isinstance(wait, At) and wait.prompt:
                    self._resolve(Reply(">", tuple(self._lines)))
                return
            if self._lines and self._lines[-1].startswith(("+CMGR:", "+CMGL:")):
                self._lines.append(line)  # an SMS's text, whatever it says ("OK", "RING")
                return
            if line.startswith("NO CARRIER") and not (
                isinstance(wait, Await) or (isinstance(wait, At) and "NO CARRIER" in wait.finals)
            ):
                return  # a connection that dropped, not this command's answer (V.250 §5.7)
            if is_final(line):
                if isinstance(wait, At) and wait.finals and not line.startswith(wait.finals):
                    log.info("late answer %r passed over while waiting for %r", line, wait)
                    self._lines.clear()
                    return
                self._resolve(Reply(line, tuple(self._lines)))
                return
            in_sms = any(ln.startswith(("+CMGR:", "+CMGL:")) for ln in self._lines)
            if is_urc(line) and not in_sms:
                self._queue_urc(line)
            else:
                self._lines.append(line)
            return
        if isinstance(wait, Urc) and line.startswith(wait.prefixes):
            self._resolve(line)
        elif is_urc(line):
            self._queue_urc(line)
        elif is_final(line) and not line.startswith("NO CARRIER"):
            # an answer nobody waits for: a late one (jobs.probe)
            self.stray_finals += 1
            self.outstanding = max(self.outstanding - 1, 0)

    def _queue_urc(self, line: str) -> None:
        if len(self._urcs) >= MAX_URCS:
            self._urcs.popleft()
            self.listing_due = True  # a dropped +CMTI is found by the listing
        self._urcs.append(line)

    def _timeout(self) -> None:
        wait = self._wait
        if isinstance(wait, At | Send):
            self.outstanding += 1  # its answer may still come, late (jobs.probe waits)
            self.last_timeout = self.now
            if self._kind != "probe":
                log.warning("no answer from the modem to %r: setting it up again", wait)
                self._lost()
        if isinstance(wait, At | Send | Await):
            self._resolve(Reply("", tuple(self._lines)))
        elif isinstance(wait, Urc):
            self._resolve(None)
        elif isinstance(wait, Recv):
            self._resolve(b"")
        else:
            self._resolve(None)

    def _forget_modem(self) -> None:
        self.applied = None
        self.gprs = self.listening = False
        self.registered_since = None

    def _lost(self) -> None:
        """gsm.md §7: a command went unanswered: the rest of the job fails at once, then a
        lone ``AT`` until the modem answers, then its set-up again."""
        self._forget_modem()
        self.present = None
        self._next_probe = self.now
        self.resync = True  # late answers must pass before the probe (jobs.probe)

    def out_of_step(self, why: str) -> None:
        """An answer that cannot be the command's own: answers and commands are out of step
        (late answers queued up); set the modem up again after a quiet time (gsm.md §7)."""
        log.warning("modem answers out of step (%s): setting it up again", why)
        self._lost()

    def _gone(self) -> None:
        self._forget_modem()
        self.present = False
        self._next_probe = self.now + PROBE_INTERVAL

    def found(self, answered: bool) -> None:
        """The result of a probe."""
        self.heard = False
        if answered:
            self.present = True
        else:
            self._gone()
            self.reader = ModemReader()

    # -- what next -----------------------------------------------------------------------
    def _schedule(self) -> None:
        for _ in range(100):  # each pass may end a job at once; never loop for ever
            if self._job is not None:
                return
            job = self._next_job()
            if job is None:
                return
            self._start(*job)

    def _next_job(self) -> tuple[str, _Running] | None:
        device = self.device
        if device == LOCAL:
            self.present, self.applied = None, None
            return None
        if self.present is not True:
            quiet = self.now >= self.host.line_quiet_since() + PROBE_QUIET
            if self.now >= self._next_probe and (quiet or self.present is None or self.heard):
                self._next_probe = self.now + PROBE_INTERVAL
                self._probed_at = self.now
                return "probe", jobs.probe(self)
            return None
        if self.reader.raw:  # data mode with no job of its own: leave it, set up again
            self.applied = None
            return "init", jobs.hang_up(self)
        if self.applied != device:
            return "init", jobs.init(self, device)
        if self._urcs:
            return self._dispatch(self._urcs.popleft())
        if self.listing_due:
            self.listing_due = False
            return "sms", jobs.list_store(self)
        reply = self._reply_due()
        if reply is not None:
            self.replies.remove(reply)
            return "reply", jobs.send_reply(self, reply)
        item = self._outgoing()
        if item is not None:
            return "send", jobs.deliver(self, item)
        if self._wants_attach() and self.now >= self._gprs_retry:
            self._gprs_retry = self.now + GPRS_RETRY
            return "idle", mailjobs.gprs_up(self)
        if device != "WAVECOM42" and self.gprs:
            return "idle", mailjobs.gprs_down(self)
        if device == "WAVECOM40" and self.radio:
            return "idle", steps.radio(self, False)
        return None

    def network_back(self) -> None:
        """Registration (re)gained: list the store, try the waiting replies now (gsm.md §7)."""
        self.listing_due = True
        for reply in self.replies:
            reply.next_try = min(reply.next_try, self.now)

    def _wants_attach(self) -> bool:
        """wavecom42 registered but not listening on port 10001 (the bearer was lost)."""
        lost = not self.listening and self.registered_since is not None
        return self.device == "WAVECOM42" and self.applied == "WAVECOM42" and lost

    def _outgoing(self) -> Outgoing | None:
        outbox = self.host.outbox
        for kind in (None, "sms", "email"):
            item = outbox.peek(kind)
            if item is not None and any(d.kind in ("sms", "email") for d in item.destinations):
                outbox.take(kind)
                return item
        return None

    def _dispatch(self, line: str) -> tuple[str, Job] | None:
        if line.startswith("+CREG:"):
            if line.split(":", 1)[1].strip() in ("1", "5"):
                if self.registered_since is None:
                    self.registered_since = self.now
                    self.network_back()
            else:  # no network: the modem dropped its bearer and sockets
                self.registered_since = None
                self.gprs = self.listening = False
        elif line.startswith("+CMTI:"):
            index = line.rsplit(",", 1)[-1].strip()
            if index.isdigit():
                return "sms", jobs.read_sms(self, int(index))
        elif line.startswith(("RING", "+CRING:")):
            clip = self.urc(("+CLIP:",))
            number = clip.split('"')[1] if clip is not None and clip.count('"') >= 2 else ""
            kind = "data" if ("ASYNC" in line or "SYNC" in line) else "voice"
            if line == "RING":
                kind = "data"  # no extended ring code: a data call is the safe guess
            return "session", jobs.call(self, kind, number)
        elif line.startswith("+WIPACCEPT:"):
            index = line.rsplit(",", 1)[-1].strip()
            if index.isdigit():
                return "session", jobs.socket_session(self, int(index))
        return None
