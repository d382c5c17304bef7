"""What the README and the tutorial claim, checked (issue 26): the install line has the
clients the docs use, and the tutorial's header example shows what a new logger answers."""

from __future__ import annotations

import re
from pathlib import Path

from sondalog.app.virtual import VirtualLogger

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = "$ printf 'sum read i version\\ncrcsum read channel name\\ncheck 890 read date\\n'"


def test_readme_apt_line_installs_mosquitto_clients() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    line = next(x for x in readme.splitlines() if x.startswith("sudo apt-get install"))
    packages = line.split()[4:]
    assert {"mosquitto", "mosquitto-clients"} <= set(packages), line  # mosquitto_sub


def test_tutorial_header_example_is_what_a_new_logger_answers() -> None:
    """Section 2 runs on a logger just served: channel 2 is only made in section 3."""
    tutorial = (ROOT / "docs" / "tutorial.md").read_text(encoding="utf-8")
    block = tutorial.split(EXAMPLE, 1)[1].split("```", 1)[0]
    _, *shown = block.strip("\n").splitlines()  # after "| sondalog term URL"
    lines = EXAMPLE.split("'")[1].split("\\n")[:-1]
    assert lines == ["sum read i version", "crcsum read channel name", "check 890 read date"]
    logger = VirtualLogger()
    try:
        answered = "".join(logger.command(line) for line in lines)
    finally:
        logger.close()
    got = answered.replace("\r\n", "\n").splitlines()
    assert len(got) == len(shown), (got, shown)
    for want, line in zip(shown, got, strict=True):
        if re.fullmatch(r"\d{14}", want):  # the logger's clock
            assert re.fullmatch(r"\d{14}", line), (want, line)
        else:
            assert line == want
