"""sondalog's TCP hot path against pymodbus and an asyncio "floor" (issue "Speed").

Not a test (DESIGN.md "Benchmarks"): prints figures and ratios. Run with
``.venv/bin/python benchmarks/bench_vs_pymodbus.py [--runs N] [--quick] [--uvloop]``.

Three servers run as separate processes, all started once and measured in the same run,
interleaved:

- sondalog: ``python -m sondalog logger serve`` with ``examples/bench-site.toml`` and 12
  channels configured through the protocol (11 analog inputs and the supply), 12 rows written
  with ``write channel value`` so that ``read record 10 from start`` answers 10 rows;
- pymodbus 3.x: ``StartAsyncTcpServer`` with a sequential holding-register block
  (``benchmarks/peers.py``);
- the floor: an asyncio server answering every line with ``2.10\\r\\nOK\\r\\n`` and doing
  nothing else (``benchmarks/peers.py``).

One client process (``benchmarks/loadgen.py``, never sharing a GIL with a server) drives each
with 50 concurrent TCP connections on loopback, the same code for all: closed loop (req/s)
and a fixed offered load of 4,000 req/s (server CPU microseconds per request, from
``/proc/<pid>/stat``; a server that cannot reach the offered load is flagged). Every figure
is given as best / median of ``--runs`` runs; ratios are of bests / of medians.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from loadgen import Job, Mode, Request, Result, client_process

ROOT = Path(__file__).resolve().parent.parent
SITE = ROOT / "examples" / "bench-site.toml"
PEERS = ROOT / "benchmarks" / "peers.py"
HOST = "127.0.0.1"
#: Run sondalog's own CLI on uvloop, whatever sondalog itself would pick.
UVLOOP_LAUNCHER = (
    "import asyncio, runpy, uvloop; asyncio.set_event_loop_policy(uvloop.EventLoopPolicy()); "
    "runpy.run_module('sondalog', run_name='__main__', alter_sys=True)"
)
#: Channels 1..11 read the site's analog inputs (32..36: same pins, external reference).
ANALOG_ADDRESSES = (16, 17, 24, 18, 19, 20, 32, 33, 34, 35, 36)
RECORD_ROWS = 12

VERSION = Request("line", line=b"read i version\r")
VALUES = Request("line", line=b"read channel value\r")
RECORD = Request("line", line=b"read record 10 from start\r")
ONE_REGISTER = Request("modbus", address=0, count=1)
TWELVE_REGISTERS = Request("modbus", address=0, count=12)


@dataclass(frozen=True)
class Row:
    title: str
    sondalog: Request
    pymodbus: Request
    floor: Request | None = None


ROWS = (
    Row("`read i version` vs read 1 holding register", VERSION, ONE_REGISTER, VERSION),
    Row("`read channel value`, 12 channels vs 12 registers", VALUES, TWELVE_REGISTERS),
    Row("`read record 10 from start` vs 12 registers", RECORD, TWELVE_REGISTERS),
)


@dataclass
class Server:
    name: str
    process: subprocess.Popen[bytes]
    host: str
    port: int
    loop: str = "asyncio"

    @property
    def pid(self) -> int:
        return self.process.pid


@dataclass
class Settings:
    runs: int
    closed: tuple[float, float]  # (window, warmup) seconds
    fixed: tuple[float, float]
    rate: float
    clients: int


# ---------------------------------------------------------------- servers


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


def _wait_accepting(name: str, process: subprocess.Popen[bytes], port: int, log: Path) -> None:
    """Wait until the server accepts a TCP connection on ``port`` (the log is not parsed)."""
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        if process.poll() is not None:
            sys.exit(f"{name} exited at start:\n{log.read_text(errors='replace')}")
        try:
            socket.create_connection((HOST, port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.02)
    process.kill()
    sys.exit(f"{name} did not accept connections within 20 s:\n{log.read_text(errors='replace')}")


@contextmanager
def running(name: str, argv: Callable[[int], list[str]], workdir: Path) -> Iterator[Server]:
    """Run ``argv(port)`` with a free port, its output going to ``NAME.log``."""
    log = workdir / f"{name}.log"
    port = free_port()
    with open(log, "wb") as out:
        process = subprocess.Popen(argv(port), stdout=out, stderr=subprocess.STDOUT)
    try:
        _wait_accepting(name, process, port, log)
        yield Server(name, process, HOST, port, loop=loop_of(process.pid))
    finally:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def loop_of(pid: int) -> str:
    """``uvloop`` when the process has uvloop's extension loaded, else ``asyncio``."""
    try:
        maps = Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return "?"
    return "uvloop" if "/uvloop/" in maps else "asyncio"


def sondalog_argv(state: Path, uvloop: bool) -> Callable[[int], list[str]]:
    head = [sys.executable, "-c", UVLOOP_LAUNCHER] if uvloop else [sys.executable, "-m", "sondalog"]

    def argv(port: int) -> list[str]:
        serve = ["logger", "serve", "--listen", f"{HOST}:{port}", "--state", str(state)]
        return [*head, *serve, "--site", str(SITE)]

    return argv


def peer_argv(*args: str) -> Callable[[int], list[str]]:
    return lambda port: [sys.executable, str(PEERS), *args, "--port", str(port)]


class SetupError(Exception):
    """A server did not answer as the benchmark needs."""


def _ask(sock: socket.socket, command: str) -> str:
    sock.sendall(command.encode() + b"\r")
    answer = b""
    while not answer.endswith((b"OK\r\n", b"ERROR\r\n")):
        chunk = sock.recv(65536)
        if not chunk:
            raise SetupError(f"connection closed after {command!r}")
        answer += chunk
    if answer.endswith(b"ERROR\r\n"):
        raise SetupError(f"refused {command!r}: {answer!r}")
    return answer.decode().removesuffix("OK\r\n")


def prepare_sondalog(server: Server) -> None:
    """Configure 12 channels, write the record rows, check every benchmarked answer."""
    with socket.create_connection((server.host, server.port), timeout=10) as sock:
        _ask(sock, "write channel max number 12")
        # No switched sensors: the factory settings power every channel's sensor through
        # output 1 with a 1 s advance (§6.5.13) and keep it on 5 s after an on-demand read
        # (§6.9), so all reads would wait a second every few seconds. Output 1 stays on
        # for the supply divider (§6.7.3).
        _ask(sock, "write output 1 value 1")
        for channel, address in enumerate(ANALOG_ADDRESSES, start=1):
            _ask(sock, f"write channel {channel} type 3 write channel {channel} address {address}")
        for channel in range(1, 13):
            _ask(sock, f"write channel {channel} switch output 0")
        for _ in range(RECORD_ROWS):
            _ask(sock, "write channel value")
        version = _ask(sock, "read i version").strip()
        values = _ask(sock, "read channel value").strip().split(",")
        rows = _ask(sock, "read record 10 from start").splitlines()
    if len(values) != 12 or not all(values):
        raise SetupError(f"`read channel value` did not answer 12 numbers: {values}")
    if len(rows) != 10:
        raise SetupError(f"`read record 10 from start` answered {len(rows)} rows")
    print(f"{server.name}: version {version}, channel values {','.join(values)}")


def check_floor(server: Server) -> None:
    with socket.create_connection((server.host, server.port), timeout=10) as sock:
        answer = _ask(sock, "read i version")
    if answer != "2.10\r\n":
        raise SetupError(f"the floor answered {answer!r}")


def check_modbus(server: Server) -> None:
    with socket.create_connection((server.host, server.port), timeout=10) as sock:
        for request in (ONE_REGISTER, TWELVE_REGISTERS):
            sock.sendall(request.payload(1))
            answer = b""
            while len(answer) < 9 + 2 * request.count:
                chunk = sock.recv(4096)
                if not chunk:
                    sys.exit(f"{server.name} closed the connection")
                answer += chunk
            if answer[7] != 3 or answer[8] != 2 * request.count:
                sys.exit(f"{server.name} answered {answer.hex()} to {request}")


# ---------------------------------------------------------------- measuring

Key = tuple[str, Request]


@dataclass
class Figures:
    closed: list[Result]
    fixed: list[Result]


def measure(
    servers: dict[str, Server],
    pairs: list[Key],
    settings: Settings,
    run: Callable[[Job], Result],
) -> dict[Key, Figures]:
    figures = {key: Figures([], []) for key in pairs}
    for index in range(settings.runs):
        print(f"run {index + 1}/{settings.runs} ...", flush=True)
        for key in pairs:
            server = servers[key[0]]
            modes: tuple[tuple[Mode, tuple[float, float]], ...] = (
                ("closed", settings.closed),
                ("fixed", settings.fixed),
            )
            for mode, (window, warmup) in modes:
                job = Job(
                    host=server.host,
                    port=server.port,
                    pid=server.pid,
                    request=key[1],
                    mode=mode,
                    seconds=window,
                    warmup=warmup,
                    clients=settings.clients,
                    rate=settings.rate,
                )
                result = run(job)
                getattr(figures[key], mode).append(result)
    return figures


# ---------------------------------------------------------------- report


def best_median(values: list[float], higher_is_better: bool) -> tuple[float, float]:
    best = max(values) if higher_is_better else min(values)
    return best, statistics.median(values)


def rates(figures: Figures) -> tuple[float, float]:
    return best_median([r.rate for r in figures.closed], True)


def cpu(figures: Figures) -> tuple[float, float]:
    return best_median([r.us_per_request for r in figures.fixed], False)


def reached(figures: Figures) -> float:
    """Median achieved rate at the fixed offered load."""
    return statistics.median(r.rate for r in figures.fixed)


def fmt(pair: tuple[float, float]) -> str:
    return f"{pair[0]:,.0f} / {pair[1]:,.0f}"


def fmt_ratio(a: tuple[float, float], b: tuple[float, float]) -> str:
    def ratio(x: float, y: float) -> str:
        return f"{x / y:.2f}" if y and math.isfinite(x) and math.isfinite(y) else "-"

    return f"{ratio(a[0], b[0])} / {ratio(a[1], b[1])}"


def cpu_cell(figures: Figures, settings: Settings) -> str:
    if not all(r.requests for r in figures.fixed):
        return "no answers"
    cell = fmt(cpu(figures))
    achieved = reached(figures)
    if achieved < 0.97 * settings.rate:
        cell += f" (cannot reach {settings.rate:,.0f}: {achieved:,.0f} req/s)"
    return cell


def print_table(
    title: str,
    sondalog: str,
    floor: str,
    figures: dict[Key, Figures],
    settings: Settings,
) -> None:
    load = f"{settings.rate:,.0f} req/s"
    print(f"\n{title} (best / median of {settings.runs}; us = server CPU microseconds)\n")
    print(
        f"| request (sondalog vs pymodbus) | sondalog req/s | pymodbus req/s "
        f"| sondalog us/req at {load} | pymodbus us/req at {load} | floor us/req |"
    )
    print("|---|---|---|---|---|---|")
    for row in ROWS:
        sl, pm = figures[(sondalog, row.sondalog)], figures[("pymodbus", row.pymodbus)]
        fl = fmt(cpu(figures[(floor, row.floor)])) if row.floor else "-"
        print(
            f"| {row.title} | {fmt(rates(sl))} | {fmt(rates(pm))} "
            f"| {cpu_cell(sl, settings)} | {cpu_cell(pm, settings)} | {fl} |"
        )
    print(
        "\n| request | req/s sondalog : pymodbus | CPU/req pymodbus : sondalog (goal >= 1.5) "
        "| CPU/req sondalog : floor (goal <= 2) |"
    )
    print("|---|---|---|---|")
    for row in ROWS:
        sl, pm = figures[(sondalog, row.sondalog)], figures[("pymodbus", row.pymodbus)]
        to_floor = fmt_ratio(cpu(sl), cpu(figures[(floor, row.floor)])) if row.floor else "-"
        print(
            f"| {row.title} | {fmt_ratio(rates(sl), rates(pm))} "
            f"| {fmt_ratio(cpu(pm), cpu(sl))} | {to_floor} |"
        )


def print_details(figures: dict[Key, Figures], settings: Settings) -> None:
    print(
        "\nDetails (medians): closed loop req/s and the CPU share of server and client (a"
        " saturated server near 100 %; lower means other processes took the core, or the"
        f" client is the limit); at {settings.rate:,.0f} req/s offered: server CPU us/req,"
        " achieved rate, latency p50/p99; errors (error answers and dropped connections)\n"
    )
    print(
        "| server | request | closed req/s | server CPU | client CPU | us/req | achieved "
        "| p50 ms | p99 ms | errors |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for (name, request), fig in figures.items():
        what = request.line.decode().strip() if request.kind == "line" else f"{request.count} reg"
        share = statistics.median(r.client_cpu / r.elapsed for r in fig.closed)
        busy = statistics.median(r.server_cpu / r.elapsed for r in fig.closed)
        latencies = sorted(x for r in fig.fixed for x in r.latencies)
        p50 = latencies[len(latencies) // 2] * 1e3 if latencies else float("nan")
        p99 = latencies[int(len(latencies) * 0.99)] * 1e3 if latencies else float("nan")
        errors = sum(r.errors + r.dropped for r in fig.closed + fig.fixed)
        print(
            f"| {name} | {what} | {rates(fig)[1]:,.0f} | {busy:.0%} | {share:.0%} "
            f"| {cpu(fig)[1]:,.0f} "
            f"| {reached(fig):,.0f} | {p50:.2f} | {p99:.2f} | {errors} |"
        )
        if errors:
            print(f"WARNING: {name}: {errors} error answers or dropped connections ({what!r})")


# ---------------------------------------------------------------- main


def parse() -> tuple[Settings, bool]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="runs (best and median of them)")
    parser.add_argument("--quick", action="store_true", help="one short run (a smoke test)")
    parser.add_argument("--uvloop", action="store_true", help="also run sondalog on uvloop")
    parser.add_argument("--rate", type=float, default=4000.0, help="fixed offered load, req/s")
    parser.add_argument("--clients", type=int, default=50, help="concurrent TCP clients")
    args = parser.parse_args()
    if args.runs < 1 or args.rate <= 0 or args.clients < 1:
        parser.error("--runs, --rate and --clients must be positive")
    if args.quick:
        settings = Settings(1, (0.5, 0.2), (1.0, 0.3), args.rate, args.clients)
    else:
        settings = Settings(args.runs, (1.5, 0.5), (2.5, 0.5), args.rate, args.clients)
    return settings, args.uvloop


def main() -> None:
    settings, want_uvloop = parse()
    # sondalog's serving commands pick uvloop when it is installed (sondalog[fast]); the
    # standard rows are measured on the standard loop, the --uvloop rows through the launcher.
    os.environ["SONDALOG_LOOP"] = "asyncio"
    uvloop = want_uvloop and importlib.util.find_spec("uvloop") is not None
    if want_uvloop and not uvloop:
        print("uvloop is not installed (pip install 'sondalog[fast]'): asyncio only")
    print(
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}; "
        f"{settings.clients} clients, python {sys.version.split()[0]}"
    )
    if os.getloadavg()[0] > 1.0:
        print("NOTE: other processes are busy on this machine; expect noisy figures")
    with tempfile.TemporaryDirectory() as tmp, ExitStack() as stack:
        work = Path(tmp)
        servers: dict[str, Server] = {}

        def start(name: str, argv: Callable[[int], list[str]]) -> Server:
            server = stack.enter_context(running(name, argv, work))
            servers[name] = server
            return server

        start("sondalog", sondalog_argv(work / "sondalog", uvloop=False))
        start("pymodbus", peer_argv("pymodbus"))
        start("floor", peer_argv("floor"))
        if uvloop:
            start("sondalog+uvloop", sondalog_argv(work / "sondalog-uv", uvloop=True))
            start("floor+uvloop", peer_argv("floor", "--uvloop"))
        sondalog_uvloop = uvloop
        for name in [name for name in servers if name.startswith("sondalog")]:
            try:
                prepare_sondalog(servers[name])
            except (SetupError, OSError) as exc:
                log = (work / f"{name}.log").read_text(errors="replace")[-1500:]
                message = f"{name} does not serve the benchmark: {exc}\n{log}"
                if name == "sondalog":
                    sys.exit(message)
                print(message)
                sondalog_uvloop = False
        check_modbus(servers["pymodbus"])
        for name in [name for name in servers if name.startswith("floor")]:
            check_floor(servers[name])
        loops = ", ".join(f"{s.name} on {s.loop}" for s in servers.values())
        print(f"event loops: {loops}")
        if servers["sondalog"].loop != "asyncio":
            print("NOTE: sondalog chose uvloop by itself; its rows are not the asyncio figures")

        pairs: list[Key] = [
            ("sondalog", VERSION),
            ("pymodbus", ONE_REGISTER),
            ("floor", VERSION),
            ("sondalog", VALUES),
            ("pymodbus", TWELVE_REGISTERS),
            ("sondalog", RECORD),
        ]
        if sondalog_uvloop:
            pairs += [("sondalog+uvloop", VERSION), ("sondalog+uvloop", VALUES)]
            pairs += [("sondalog+uvloop", RECORD)]
        if uvloop:
            pairs.append(("floor+uvloop", VERSION))
        started = time.monotonic()
        with client_process() as clients:
            figures = measure(servers, pairs, settings, clients.run)
        print(f"measured in {time.monotonic() - started:.0f} s")
        print_table("Standard asyncio loop", "sondalog", "floor", figures, settings)
        if sondalog_uvloop:
            print_table(
                "sondalog and floor on uvloop (pymodbus on asyncio)",
                "sondalog+uvloop",
                "floor+uvloop",
                figures,
                settings,
            )
        print_details(figures, settings)


if __name__ == "__main__":
    main()
