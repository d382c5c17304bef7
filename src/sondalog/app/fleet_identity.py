"""A fleet's identities: every logger's ``STATE/loggers/SERIAL/identity.json`` (issue 24).

The files are those of a single logger (:func:`sondalog.app.logger.load_identity`: the same
text, the same refusal of another protocol or serial number), read or written for thousands
of loggers at once:

- the state's directories are listed once; an existing ``identity.json`` is read in
  threads (a cold disk's reads overlap), a few hundred a task;
- the new ones are written without an fsync each. A fresh fleet of 10,000 loggers spent
  about 3.5 s of CPU (and more wall time) on 10,000 fsyncs, each a commit of the file
  system's journal. Instead every new file is written beside its place (``identity.tmp``),
  then the file system is synced once (``syncfs``), then the files are renamed into place
  and the file system is synced once more. A crash before the first sync leaves no
  ``identity.json`` (the logger is new again at the next start, as before its first one); a
  crash before the second leaves some renamed or not, each whole. So the identities are
  durable before anything the loggers commit is, as with an fsync each, at two syncs.

``syncfs`` (Linux) writes what is dirty on the file system of the state only; where the C
library has none, ``os.sync`` writes every file system's.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from sondalog.ala1 import Identity, Version
from sondalog.app.fleet_site import FleetLogger
from sondalog.app.logger import IDENTITY_FILE, IdentityConflict, identity_text, parse_identity
from sondalog.config import ConfigError
from sondalog.io.private import open_private, private_dir

#: Threads that read the loggers' identity files at start.
IDENTITY_THREADS = 16
_TMP = "identity.tmp"
_VERSIONS = {version.value: version for version in Version}


def read_identities(
    loggers: Sequence[FleetLogger], states: Path, path: Path | None
) -> tuple[list[Identity], list[Identity]]:
    """Every logger's identity, read from ``states/SERIAL`` or (a new logger) made from its
    plan; and the new ones (for :func:`write_identities`). A logger whose state holds
    another protocol or serial number raises ConfigError naming its entry (the first such
    logger in order)."""
    with os.scandir(states) as listing:
        present = {entry.name for entry in listing if entry.is_dir(follow_symlinks=False)}
    found: list[Identity | IdentityConflict | None] = [None] * len(loggers)
    old = [i for i, plan in enumerate(loggers) if plan.serial_number in present]
    size = max(1, -(-len(old) // (IDENTITY_THREADS * 4)))
    chunks = [old[i : i + size] for i in range(0, len(old), size)]

    def read(chunk: list[int]) -> None:
        for index in chunk:
            found[index] = _read(states / loggers[index].serial_number, loggers[index])

    if len(chunks) > 1:
        with ThreadPoolExecutor(max_workers=IDENTITY_THREADS) as pool:
            list(pool.map(read, chunks))
    elif chunks:
        read(chunks[0])
    identities: list[Identity] = []
    new: list[Identity] = []
    for plan, identity in zip(loggers, found, strict=True):
        if isinstance(identity, IdentityConflict):
            raise ConfigError(path, f"{plan.where}.protocol", str(identity)) from identity
        if identity is None:
            version = _VERSIONS[plan.protocol] if plan.protocol else Version.V2_10
            identity = Identity(version, plan.serial_number)
            new.append(identity)
        identities.append(identity)
    return identities, new


def _read(directory: Path, plan: FleetLogger) -> Identity | IdentityConflict | None:
    """The identity in ``directory`` (None: none yet), or why it is not ``plan``'s."""
    try:
        text = (directory / IDENTITY_FILE).read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    version = _VERSIONS[plan.protocol] if plan.protocol is not None else None
    try:
        return parse_identity(directory, text, version, plan.serial_number)
    except IdentityConflict as conflict:  # (raised in order by the caller)
        return conflict


def write_identities(states: Path, new: Sequence[Identity]) -> None:
    """Write the new loggers' identities (:func:`read_identities`) durably, with two syncs
    of the file system. (In turn: in a thread beside the loop building the engines, each
    of its system calls waited for the interpreter's switch interval.)"""
    if not new:
        return
    for identity in new:
        directory = private_dir(states / identity.serial_number)
        with open_private(directory / _TMP) as handle:
            handle.write(identity_text(identity))
    sync_file_system(states)  # every new file's content on disk before any is in place
    for identity in new:
        directory = states / identity.serial_number
        os.replace(directory / _TMP, directory / IDENTITY_FILE)
    sync_file_system(states)  # and the names


def sync_file_system(path: Path) -> None:
    """Write to disk what is dirty on the file system holding ``path`` (``syncfs``; where
    the C library has none, every file system's: ``os.sync``)."""
    syncfs = getattr(_libc(), "syncfs", None)
    if syncfs is None:
        os.sync()
        return
    fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    try:
        if syncfs(fd) != 0:
            error = ctypes.get_errno()
            raise OSError(error, os.strerror(error), str(path))
    finally:
        os.close(fd)


def _libc() -> ctypes.CDLL | None:
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:
        return None
