"""Soak of the GSM driver's liveness (gsm.md §7): thousands of random schedules of the pure
world of ``tests/world/liveness_machine.py`` (SMS, calls, coverage, messages, mail, a slow
and stalling modem line, cable sessions), each followed by quiet and the liveness checks.

    python benchmarks/soak_gsm.py --schedules 5000 --seed 1

Prints how many schedules ran and how many failed, with the seeds of the failures (each
replays with ``--seed S --schedules 1 -v``). Not a test: ``make test`` runs a few hundred
schedules through hypothesis (tests/world/test_modem_liveness_search.py).
"""

from __future__ import annotations

import argparse
import logging
import random
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "world"))

import liveness_machine as lm

RULES: dict[str, Any] = {
    "wait": lambda r: {"seconds": r.choice([0.0, 0.003, 0.05, 0.4, 1.0, 3.0, 12.0, 45.0, 130.0])},
    "line_latency": lambda r: {"latency": r.choice([0.0, 0.0, 0.002, 0.05, 0.3])},
    "line_cuts": lambda r: {"seed": r.randrange(65536), "density": r.choice([0, 2, 8, 40])},
    "modem_stalls": lambda r: {"seconds": r.choice([11.0, 25.0, 70.0])},
    "sms_command": lambda r: {},
    "sms_long_reply": lambda r: {},
    "sms_reply_by_mail": lambda r: {},
    "sms_without_command": lambda r: {
        "text": r.choice(["hi", "teplota 5°C ✓", "RING", "\r\nOK\r\n", '+CMTI: "SM",9', ""])
    },
    "call": lambda r: {"kind": r.choice(["voice", "data"]), "ring": r.random() < 0.5},
    "caller_types": lambda r: {
        "data": r.choice([b"read i version\r", b"read i vers", b"\x1b", b"ion\r\n"])
    },
    "caller_hangs_up": lambda r: {},
    "coverage": lambda r: {"covered": r.random() < 0.5},
    "network_restarts": lambda r: {},
    "idle_mode": lambda r: {"device": r.choice(["wavecom40", "wavecom41", "wavecom42"])},
    "mail_servers": lambda r: {
        "refuse": r.random() < 0.5,
        "pop3_delay": r.choice([0.0, 0.0, 20.0, 200.0]),
    },
    "mail_command_waits": lambda r: {},
    "message_falls_due": lambda r: {},
    "cable_session": lambda r: {},
}


def schedule(seed: int, steps: int, verbose: bool) -> str | None:
    """One schedule; None when every property held, else what failed."""
    rng = random.Random(seed)
    machine = lm.GsmLiveness()
    machine.start(device=rng.choice(["wavecom41", "wavecom42"]))
    try:
        for _ in range(steps):
            name = rng.choice(sorted(RULES))
            args = RULES[name](rng)
            if verbose:
                print(f"  {name}({args})")
            getattr(machine, name)(**args)
        machine.teardown()
    except AssertionError as failure:
        return str(failure)[:300]
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--schedules", type=int, default=2000)
    parser.add_argument("--steps", type=int, default=25)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("-v", "--verbose", action="store_true")
    args = parser.parse_args()
    if not args.verbose:
        logging.disable(logging.CRITICAL)
    started = time.perf_counter()
    failed: list[tuple[int, str]] = []
    for seed in range(args.seed, args.seed + args.schedules):
        why = schedule(seed, args.steps, args.verbose)
        if why is not None:
            failed.append((seed, why))
    elapsed = time.perf_counter() - started
    print(f"schedules run: {args.schedules} ({args.steps} steps each) in {elapsed:.1f} s")
    print(f"schedules failed: {len(failed)}")
    for seed, why in failed[:20]:
        print(f"  seed {seed}: {why}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
