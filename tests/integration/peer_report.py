"""A pytest plugin: at the end of the run, name the real peers whose absence skipped tests and
print the command that installs them (issue 16, item 6: ``make test`` must not skip silently).

The tests skip with a reason that names the missing program (``socat is not installed``);
:data:`PEERS` maps those names to Debian packages. The hook sees every skip of the session,
in any folder; it is loaded by ``tests/integration/conftest.py`` (a ``tests/conftest.py``
would make ``conftest`` a first-party module for ruff's import order in every test folder),
and usable on its own with ``pytest -p peer_report``.
"""

from __future__ import annotations

import re

import pytest

#: peer -> (Debian packages, a pattern matching the skip reasons that mean it is missing)
PEERS: dict[str, tuple[str, str]] = {
    "socat": ("socat", r"\bsocat\b"),
    "lrzsz": ("lrzsz", r"\blrzsz\b|\b[sr][xzb]\b"),
    "gammu": ("gammu", r"\bgammu"),
    "dovecot": ("dovecot-core dovecot-pop3d", r"\bdovecot"),
    "postgresql": ("postgresql", r"postgres|\binitdb\b|\bpg_ctl\b"),
    "mosquitto": ("mosquitto", r"\bmosquitto"),
    "chromium": ("chromium", r"chromium|\bbrowser\b|playwright"),
}


def _reason(report: pytest.TestReport) -> str:
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2]).removeprefix("Skipped: ")
    return str(longrepr)


def missing_peers(reasons: list[str]) -> dict[str, list[str]]:
    """peer -> the skip reasons that name it, for the peers some reason names."""
    found: dict[str, list[str]] = {}
    for reason in reasons:
        for peer, (_, pattern) in PEERS.items():
            if re.search(pattern, reason, re.IGNORECASE):
                found.setdefault(peer, []).append(reason)
                break
    return found


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    skipped = terminalreporter.stats.get("skipped", [])
    reasons = [_reason(r) for r in skipped if isinstance(r, pytest.TestReport)]
    missing = missing_peers(reasons)
    if not missing:
        return
    terminalreporter.section("real peers missing: tests skipped", yellow=True)
    for peer, why in missing.items():
        terminalreporter.write_line(f"{len(why):4d} skipped without {peer}: {why[0]}")
    packages = " ".join(sorted({p for peer in missing for p in PEERS[peer][0].split()}))
    terminalreporter.write_line("Install them (Debian, Ubuntu) and run make test again:")
    terminalreporter.write_line(f"    sudo apt-get install -y {packages}")
