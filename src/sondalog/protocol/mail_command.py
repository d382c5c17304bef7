"""Commands in SMS and e-mail texts, and the logger's outgoing e-mail (pure).

- The command is the text between the first two occurrences of ``sms command boundary``
  (§6.12.1, factory ``##*#``), whitespace at both ends removed. A text without two
  boundaries, or with nothing between them, holds no command (gsm.md §4).
- An SMS may name a return address between ``sms email address start`` and ``end``
  (§6.12.2, factory ``startemail`` / ``endemail``), searched outside the command. A missing
  end marker or a text there that is no e-mail address: no return address (the reply goes
  back by SMS), and :attr:`BoundedCommand.note` says why.
- An e-mail command (§3.4.6.2) is read from the first text/plain part that is not an
  attachment, its quoted-printable or base64 transfer encoding and its charset decoded
  strictly; its reply goes to the Reply-To address, else the From address. Anything that
  cannot be read yields :class:`NoCommand` with the reason.
- The logger's e-mail (§6.13): From ``email send from``, To the address, Subject
  ``email send subject``, a text/plain body that is the response exactly as the line carries
  it (lines ending CRLF); 7bit when it is ASCII, else UTF-8 quoted-printable.
"""

from __future__ import annotations

import base64
import binascii
import email.header
import email.utils
from dataclasses import dataclass
from datetime import datetime
from email import policy
from email.message import EmailMessage, Message
from email.parser import BytesParser

from .mail_address import MailAddressError, check_address

FACTORY_BOUNDARY = "##*#"
FACTORY_START = "startemail"
FACTORY_END = "endemail"


@dataclass(frozen=True)
class BoundedCommand:
    """A command found in a text, and the return address written beside it (if any)."""

    command: str
    return_address: str | None = None
    note: str = ""


@dataclass(frozen=True)
class NoCommand:
    """A text or e-mail that holds no command the logger can run, and why."""

    reason: str


@dataclass(frozen=True)
class MailCommand:
    """A command read from an e-mail, and where its reply goes (Reply-To, else From)."""

    command: str
    reply_to: str
    subject: str


def extract_command(
    text: str,
    boundary: str = FACTORY_BOUNDARY,
    start: str = FACTORY_START,
    end: str = FACTORY_END,
) -> BoundedCommand | NoCommand:
    """The bounded command of an SMS or e-mail text (§6.12.1, §6.12.2)."""
    if not boundary:
        return NoCommand("the command boundary is empty")
    first = text.find(boundary)
    if first < 0:
        return NoCommand(f"no command boundary {boundary!r}")
    second = text.find(boundary, first + len(boundary))
    if second < 0:
        return NoCommand(f"the command boundary {boundary!r} occurs only once")
    command = text[first + len(boundary) : second].strip(" \t\r\n")
    if not command:
        return NoCommand("nothing between the command boundaries")
    rest = text[:first] + "\n" + text[second + len(boundary) :]
    address, note = _return_address(rest, start, end)
    return BoundedCommand(command, address, note)


def _return_address(text: str, start: str, end: str) -> tuple[str | None, str]:
    if not start or not end:
        return None, ""
    i = text.find(start)
    if i < 0:
        return None, ""
    j = text.find(end, i + len(start))
    if j < 0:
        return None, f"{start!r} without {end!r}: reply by SMS"
    candidate = text[i + len(start) : j]
    try:
        return check_address(candidate), ""
    except MailAddressError:
        return None, f"{candidate.strip()[:60]!r} is no e-mail address: reply by SMS"


def parse_command_mail(
    raw: bytes,
    boundary: str = FACTORY_BOUNDARY,
) -> MailCommand | NoCommand:
    """The command of a downloaded e-mail (§3.4.6.2) and its reply address."""
    try:
        msg = BytesParser(policy=policy.compat32).parsebytes(raw)
        reply_to = _first_address(msg.get_all("Reply-To", [])) or _first_address(
            msg.get_all("From", [])
        )
        subject = str(email.header.make_header(email.header.decode_header(msg["Subject"] or "")))
    except Exception as exc:  # bad input of any shape is a reason, never a crash
        return NoCommand(f"unreadable headers: {exc}")
    if reply_to is None:
        return NoCommand("no Reply-To or From address to answer")
    part = _first_plain_part(msg)
    if part is None:
        return NoCommand("no text/plain part")
    body = _decode(part)
    if isinstance(body, NoCommand):
        return body
    found = extract_command(body, boundary, "", "")
    if isinstance(found, NoCommand):
        return found
    return MailCommand(found.command, reply_to, subject)


def _first_address(values: list[str]) -> str | None:
    for _name, addr in email.utils.getaddresses([str(v) for v in values]):
        try:
            return check_address(addr)
        except MailAddressError:
            continue
    return None


def _first_plain_part(msg: Message) -> Message | None:
    for part in msg.walk():
        if part.is_multipart() or part.get_content_type() != "text/plain":
            continue
        if (part.get("Content-Disposition") or "").strip().lower().startswith("attachment"):
            continue
        return part
    return None


def _decode(part: Message) -> str | NoCommand:
    cte = str(part.get("Content-Transfer-Encoding") or "7bit").strip().lower()
    if cte == "base64":
        payload = part.get_payload(decode=False)
        try:  # strictly: the email package would quietly skip bad characters
            data = base64.b64decode("".join(str(payload).split()), validate=True)
        except (binascii.Error, ValueError):
            return NoCommand("broken base64 body")
    elif cte in ("quoted-printable", "7bit", "8bit", "binary"):
        raw = part.get_payload(decode=True)  # the bytes as sent, quoted-printable undone
        if not isinstance(raw, bytes):
            return NoCommand("text/plain part without a body")
        data = raw
    else:
        return NoCommand(f"unknown transfer encoding {cte[:30]!r}")
    charset = part.get_content_charset() or "us-ascii"
    try:
        return data.decode(charset)
    except LookupError:
        return NoCommand(f"unknown charset {charset[:30]!r}")
    except UnicodeDecodeError:
        if charset in ("us-ascii", "ascii"):
            try:  # a common fault: UTF-8 text without a charset parameter
                return data.decode("utf-8")
            except UnicodeDecodeError:
                pass
        return NoCommand(f"body is not valid {charset[:30]}")


def build_mail(
    sender: str,
    recipient: str,
    subject: str,
    body: str,
    *,
    date: datetime | None = None,
    message_id: str | None = None,
) -> bytes:
    """The logger's e-mail (§6.13) as bytes with CRLF line ends, ready for SMTP DATA."""
    msg = EmailMessage(policy=policy.SMTP)
    msg["From"] = sender
    msg["To"] = recipient
    msg["Subject"] = subject
    if date is not None:
        msg["Date"] = email.utils.format_datetime(date)
    if message_id is not None:
        msg["Message-ID"] = message_id
    lines = body.replace("\r\n", "\n").split("\n")
    plain = body.isascii() and all(len(ln) <= 998 for ln in lines)
    cte = "7bit" if plain else "quoted-printable"
    msg.set_content(body, subtype="plain", charset="us-ascii" if plain else "utf-8", cte=cte)
    return msg.as_bytes()
