"""Private state on disk: directories 0700, files 0600, whatever the umask (docs/security.md).

Everything sondalog keeps between runs is state, and state holds secrets: the logger's
non-volatile memory has its ``i address`` and the SMTP/POP3 ``user:password``, the mail hub's
Maildirs hold the messages, a modem trace holds the logger's mail conversations. Only the
user running sondalog may read it. A mode given to ``mkdir`` or ``open`` is masked by the
process umask, so every helper here sets the mode again with ``chmod`` after creating.

- :func:`private_dir`: a state directory (and its missing parents) 0700; an existing state
  directory is made 0700 too (state left by an older version).
- :func:`private_parents`: the missing directories above a file 0700; directories that
  already exist (the user's working directory, ``/tmp``) are left alone.
- :func:`open_private`: a text file opened for writing or appending, 0600.
- :func:`connect_private`: an SQLite database created 0600 before SQLite opens it; SQLite
  gives its ``-wal``, ``-shm`` and ``-journal`` files the database file's permissions, and
  any left by an older version are set to 0600 here.

Files the user names as *outputs* (an exported CSV, ``tables --out``) keep the usual
permissions; they are not made here.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
from pathlib import Path
from typing import Literal, TextIO

PRIVATE_DIR = 0o700
PRIVATE_FILE = 0o600
#: The files SQLite keeps beside a database.
SQLITE_SIDECARS = ("-wal", "-shm", "-journal")


def private_parents(path: Path | str) -> None:
    """Create the missing directories above ``path``, each 0700; existing ones are kept."""
    _make_missing(Path(path).parent)


def private_dir(path: Path | str) -> Path:
    """``path`` as a directory only its owner can enter (0700), created with any missing
    parents (0700 each; existing parents are left alone). An existing ``path`` is set to
    0700 as well, unless it belongs to another user (then it is left as it is)."""
    path = Path(path)
    created = _make_missing(path)
    if not created:
        # state made by an older version, or by the user: ours now. A directory of another
        # user cannot be changed; the files we put in it are still 0600.
        with contextlib.suppress(PermissionError):
            os.chmod(path, PRIVATE_DIR)
    return path


def _make_missing(path: Path) -> bool:
    """Create ``path`` and its missing parents 0700; True when ``path`` was created."""
    if path.is_dir():
        return False
    if path.parent != path:
        _make_missing(path.parent)
    try:
        os.mkdir(path, PRIVATE_DIR)
    except FileExistsError:
        if not path.is_dir():
            raise
        return False  # made meanwhile by someone else: not ours to change
    os.chmod(path, PRIVATE_DIR)  # the mode of mkdir was masked by the umask
    return True


def private_file(path: Path | str) -> None:
    """Make sure ``path`` exists (empty when new) and is 0600; its content is kept."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC, PRIVATE_FILE)
    try:
        os.fchmod(fd, PRIVATE_FILE)
    finally:
        os.close(fd)


def open_private(path: Path | str, mode: Literal["w", "a"] = "w", *, buffering: int = -1) -> TextIO:
    """``path`` opened as UTF-8 text for writing (``"w"``, truncated) or appending
    (``"a"``), 0600 whether it is new or not."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC
    flags |= os.O_TRUNC if mode == "w" else os.O_APPEND
    fd = os.open(path, flags, PRIVATE_FILE)
    try:
        os.fchmod(fd, PRIVATE_FILE)
        return open(fd, mode, encoding="utf-8", buffering=buffering)
    except BaseException:
        os.close(fd)
        raise


def connect_private(
    path: Path | str,
    *,
    isolation_level: Literal["DEFERRED", "EXCLUSIVE", "IMMEDIATE"] | None = None,
    check_same_thread: bool = True,
) -> sqlite3.Connection:
    """``sqlite3.connect(path)`` with the database file (and any ``-wal``/``-shm``/
    ``-journal`` beside it) 0600 before SQLite opens it. ``":memory:"`` is passed through.

    Why not set the umask around the connect: the umask is the whole process's, and other
    threads (mail delivery, the collector's sinks) create files at the same time."""
    name = os.fspath(path)
    if name not in ("", ":memory:") and not name.startswith("file:"):
        try:  # an existing file is not opened here: closing a descriptor of it would drop
            os.chmod(name, PRIVATE_FILE)  # the POSIX locks this process's other SQLite
        except FileNotFoundError:  # connections hold on it (then another process may
            private_file(name)  # checkpoint and delete the WAL under them: disk I/O error)
        for suffix in SQLITE_SIDECARS:
            with contextlib.suppress(FileNotFoundError):
                os.chmod(name + suffix, PRIVATE_FILE)
    return sqlite3.connect(
        name, isolation_level=isolation_level, check_same_thread=check_same_thread
    )
