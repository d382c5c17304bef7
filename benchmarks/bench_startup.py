"""Start-up time of the ``sondalog`` command line (issue "Speed": <= 150 ms, serve < 0.5 s).

Not a test (DESIGN.md "Benchmarks"): prints figures. Run with
``.venv/bin/python benchmarks/bench_startup.py [--runs N]``.

- ``sondalog --help``: wall time of the virtualenv's console script, to its exit;
- ``sondalog logger serve``: from spawning the process to the first TCP connection that is
  accepted and answers ``read i version`` (the client retries connecting every 2 ms), with a
  new state directory (first start: the state is created) and with an existing one (restart);
- for reference, the bare interpreter (``python -c pass``) and ``python -c "import sondalog"``.

"cached" rows run with a bytecode cache, as a user's install has after its first run: the
cache lives in a temporary ``PYTHONPYCACHEPREFIX`` (nothing is written into the source tree),
filled by one warm-up run. "as is" rows inherit this environment; with
``PYTHONDONTWRITEBYTECODE=1`` and no ``__pycache__`` in ``src/``, every run compiles
sondalog's sources again (tens of milliseconds).

Each figure is the best and the median of ``--runs`` runs (default 10).
"""

from __future__ import annotations

import argparse
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

HOST = "127.0.0.1"
BIN = Path(sys.executable).parent
VERSION_LINE = b"read i version\r"


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


Env = dict[str, str]


def wall(argv: list[str], env: Env) -> float:
    start = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, env=env)
    return time.perf_counter() - start


def _answers_version(port: int) -> bool:
    try:
        with socket.create_connection((HOST, port), timeout=5) as sock:
            sock.sendall(VERSION_LINE)
            answer = b""
            while not answer.endswith(b"OK\r\n"):
                chunk = sock.recv(1024)
                if not chunk:
                    return False
                answer += chunk
            return True
    except OSError:
        return False


def serve_ready(state: Path, env: Env) -> float:
    """Seconds from spawning ``sondalog logger serve`` to an answered ``read i version``."""
    port = free_port()
    argv = [str(BIN / "sondalog"), "logger", "serve", "--listen", f"{HOST}:{port}"]
    start = time.perf_counter()
    process = subprocess.Popen(
        [*argv, "--state", str(state)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env
    )
    try:
        while not _answers_version(port):
            if process.poll() is not None:
                assert process.stderr is not None
                sys.exit(f"sondalog logger serve exited: {process.stderr.read().decode()}")
            if time.perf_counter() - start > 20:
                sys.exit("sondalog logger serve did not answer within 20 s")
            time.sleep(0.002)
        return time.perf_counter() - start
    finally:
        process.terminate()
        process.wait(timeout=10)


def report(name: str, runs: int, measure: Callable[[], float], goal: str = "") -> None:
    times = [measure() for _ in range(runs)]
    best, median = min(times) * 1e3, statistics.median(times) * 1e3
    print(f"| {name} | {best:,.0f} | {median:,.0f} | {goal} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="runs (best and median of them)")
    args = parser.parse_args()
    if args.runs < 1:
        parser.error("--runs must be positive")
    sondalog = BIN / "sondalog"
    if not sondalog.exists():
        sys.exit(f"{sondalog} is missing: install the package into this virtualenv first")
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}, runs {args.runs}")
    dont_write = os.environ.get("PYTHONDONTWRITEBYTECODE", "")
    print(f"as is: PYTHONDONTWRITEBYTECODE={dont_write or '(unset)'}\n")
    print("| start-up | best ms | median ms | goal |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        as_is = dict(os.environ)
        cached = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        cached["PYTHONPYCACHEPREFIX"] = str(work / "pycache")
        python = sys.executable
        help_argv = [str(sondalog), "--help"]
        wall(help_argv, cached)  # fill the cache
        serve_ready(work / "kept", cached)  # create the state once, fill the cache

        def first_start() -> float:
            state = work / "first"
            shutil.rmtree(state, ignore_errors=True)
            return serve_ready(state, cached)

        rows: list[tuple[str, Callable[[], float], str]] = [
            ("`python -c pass` (the interpreter)", lambda: wall([python, "-c", "pass"], as_is), ""),
            (
                "`python -c 'import sondalog'`, cached",
                lambda: wall([python, "-c", "import sondalog"], cached),
                "",
            ),
            ("`sondalog --help`, cached", lambda: wall(help_argv, cached), "<= 150"),
            ("`sondalog --help`, as is", lambda: wall(help_argv, as_is), "<= 150"),
            ("`sondalog logger serve` to an answer, new state, cached", first_start, "< 500"),
            (
                "`sondalog logger serve` to an answer, existing state, cached",
                lambda: serve_ready(work / "kept", cached),
                "< 500",
            ),
            (
                "`sondalog logger serve` to an answer, existing state, as is",
                lambda: serve_ready(work / "kept", as_is),
                "< 500",
            ),
        ]
        for name, measure, goal in rows:
            report(name, args.runs, measure, goal)


if __name__ == "__main__":
    main()
