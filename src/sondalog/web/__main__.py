"""``python -m sondalog.web --store FILE|postgresql://...``: the dashboard alone, over an
existing store.

The collector serves the dashboard itself (``[web] listen``); this entry point is for
looking at a store without running a collector. ``--store`` names the collector's SQLite
file, or the PostgreSQL server its ``[postgres]`` sink writes (a ``postgresql://`` URL or
``key=value`` words); with a server ``--file`` may name the collector's file too (sources,
events, channel types, alarms). Bad options: a message and exit code 2.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path

from sondalog.config import ConfigError, parse_listen

from .app import create_app
from .server import check_listen, serve

#: The --help text: plain, unlike the module docstring (``--help`` prints it as it is).
DESCRIPTION = (
    "The dashboard alone, over an existing store (the collector's SQLite file, or the "
    "PostgreSQL server of its [postgres] sink). The collector "
    "serves the dashboard itself ([web] listen in its config); this is for looking at a store "
    "without running a collector. Bad options: a message and exit code 2."
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sondalog.web", description=DESCRIPTION)
    parser.add_argument(
        "--store",
        required=True,
        metavar="FILE|DSN",
        help="the collector's SQLite file, or its PostgreSQL server (postgresql://... or "
        "'host=... dbname=...')",
    )
    parser.add_argument(
        "--file",
        type=Path,
        metavar="FILE",
        help="with a server as --store: the collector's SQLite file (sources, events, "
        "channel types and alarms; without it the pages say the alarms are unavailable)",
    )
    parser.add_argument(
        "--listen",
        default="127.0.0.1:8080",
        metavar="HOST:PORT",
        help="where to serve (default 127.0.0.1:8080; loopback unless --allow-remote)",
    )
    parser.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a non-loopback address (needs the token in $SONDALOG_WEB_TOKEN)",
    )
    parser.add_argument(
        "--poll", type=float, default=1.0, metavar="SECONDS", help="live update poll (default 1)"
    )
    args = parser.parse_args(argv)
    try:
        host, port = parse_listen(args.listen)
    except ValueError as exc:
        parser.error(f"--listen: {exc}")
    if args.poll <= 0:
        parser.error("--poll: must be more than 0")
    try:
        dsn = store_dsn(args.store)
    except ValueError as exc:
        parser.error(str(exc))
    if dsn is None and args.file is not None:
        parser.error("--file: only with a PostgreSQL server as --store")
    path = args.file if dsn is not None else Path(args.store)
    token = os.environ.get("SONDALOG_WEB_TOKEN") or None
    try:
        check_listen(host, allow_remote=args.allow_remote, token=token, field="--listen")
        app = create_app(path, token=token, poll_interval=args.poll, readings_dsn=dsn)

        def listening(h: str, p: int) -> None:
            print(f"dashboard on http://{h}:{p}/", flush=True)

        asyncio.run(serve(app, host, port, allow_remote=args.allow_remote, on_listen=listening))
    except OSError as exc:  # the address is taken, or not this machine's
        print(
            f"python -m sondalog.web: cannot listen on {args.listen}: {exc.strerror or exc}",
            file=sys.stderr,
        )
        return 2
    except ConfigError as exc:
        print(f"python -m sondalog.web: {exc.field}: {exc.message}", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"python -m sondalog.web: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0
    return 0


def store_dsn(text: str) -> str | None:
    """``--store`` as a PostgreSQL connection string (a URL, or ``key=value`` words: ``=``
    in the text), None for a file (an existing file wins). A bad one: ``ValueError``."""
    if Path(text).exists() or (
        not text.startswith(("postgresql://", "postgres://")) and "=" not in text
    ):
        return None
    from psycopg import ProgrammingError, conninfo

    try:
        conninfo.conninfo_to_dict(text)
    except ProgrammingError as exc:
        raise ValueError(f"--store: not a valid PostgreSQL connection string: {exc}") from None
    return text


if __name__ == "__main__":
    sys.exit(main())
