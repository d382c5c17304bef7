"""``python -m sondalog.web --store FILE``: the dashboard alone, over an existing store.

The collector serves the dashboard itself (``[web] listen``); this entry point is for
looking at a store without running a collector. Bad options: a message and exit code 2.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path

from .app import create_app
from .server import WebConfigError, serve


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sondalog.web", description=__doc__)
    parser.add_argument("--store", type=Path, required=True, help="the collector's SQLite file")
    parser.add_argument("--listen", default="127.0.0.1:8080", help="HOST:PORT (loopback)")
    parser.add_argument(
        "--allow-remote",
        action="store_true",
        help="allow a non-loopback address (needs the token in $SONDALOG_WEB_TOKEN)",
    )
    parser.add_argument("--poll", type=float, default=1.0, help="live update poll, seconds")
    args = parser.parse_args(argv)
    host, sep, port_text = args.listen.rpartition(":")
    if not sep or not port_text.isdigit() or not host or int(port_text) > 65535:
        parser.error(f"--listen: expected HOST:PORT, got {args.listen!r}")
    if args.poll <= 0:
        parser.error("--poll: must be more than 0")
    token = os.environ.get("SONDALOG_WEB_TOKEN") or None
    try:
        app = create_app(args.store, token=token, poll_interval=args.poll)

        def listening(h: str, p: int) -> None:
            print(f"dashboard on http://{h}:{p}/", flush=True)

        asyncio.run(
            serve(app, host, int(port_text), allow_remote=args.allow_remote, on_listen=listening)
        )
    except (WebConfigError, ValueError, OSError) as exc:
        print(f"python -m sondalog.web: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
