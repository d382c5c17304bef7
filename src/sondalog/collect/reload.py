"""A running collector takes its file again on SIGHUP (``sondalog collect``, docs/collector.md).

:func:`reloading` waits for a wake (the CLI sets it from its SIGHUP handler), reads the file
again through the one reader (:func:`~sondalog.collect.config.load_config`) and hands its
source list to :meth:`Collector.reload <sondalog.collect.runner.Collector.reload>`: added
sources start, removed ones stop (their kept connections close), changed ones start again
with their new settings. A file that does not load (``FILE:LINE: field: message``) or a
collector that takes no new list (``[cluster]``) is one error line in the log, and the
collector goes on with what it runs. What a reload does not take (the store, the buffer, the
sinks, the dashboard, the alarms) is named in a warning when the file changed it; a collector of
a ``[cluster]``, or a file that adds one, is refused as a whole.

Wakes that come during a reload are one more reload after it, never two at once.
"""

from __future__ import annotations

import asyncio
import logging
from pathlib import Path

from sondalog.collect.config import CollectorConfig, load_config
from sondalog.collect.runner import Collector
from sondalog.config import ConfigError

log = logging.getLogger(__name__)

#: The parts of the file a reload leaves as they were loaded, by the name a user reads.
_KEPT = {
    "store": "[sqlite] path",
    "keep_readings": "[sqlite] readings",
    "buffer": "[buffer]",
    "sinks": "the sinks' tables",
    "web": "[web]",
    "alarms": "[[alarm]] and [[notify]]",
}


def untaken(running: CollectorConfig, loaded: CollectorConfig) -> list[str]:
    """What ``loaded`` changes that a reload does not take (a restart does)."""
    return [
        label for name, label in _KEPT.items() if getattr(running, name) != getattr(loaded, name)
    ]


async def reload_file(collector: Collector, path: Path) -> bool:
    """Read ``path`` again and take its sources; False (logged) when it was refused."""
    try:
        config = load_config(path)
        changes = untaken(collector.config, config)
        added, removed, changed = await collector.reload(config)
    except ConfigError as exc:  # (the message names the file and line)
        log.error("reload refused, the running configuration is kept: %s", exc)
        return False
    except ValueError as exc:
        log.error("reload refused, the running configuration is kept: %s: %s", path, exc)
        return False
    except Exception as exc:  # a reader's or a reload's bug (or one racing a stop): the
        # reloads go on, and so does the collecting
        log.error("reload of %s failed: %s: %s", path, type(exc).__name__, exc)
        return False
    log.warning(
        "reloaded %s: %d sources (%d added, %d removed, %d changed)",
        path,
        len(config.sources),
        added,
        removed,
        changed,
    )
    if changes:
        log.warning("reload: %s take effect at a restart", ", ".join(changes))
    return True


async def reloading(collector: Collector, path: Path, wake: asyncio.Event) -> None:
    """Reload ``path`` every time ``wake`` is set, one reload at a time, until cancelled."""
    while True:
        await wake.wait()
        wake.clear()
        await reload_file(collector, path)
