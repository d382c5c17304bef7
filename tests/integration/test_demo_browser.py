"""The demo's dashboard in a real browser: Debian's chromium driven by playwright.

Starts ``python -m sondalog.demo``, opens the overview and the rain logger's plot, checks what
they show and that a live reading arrives, and takes the screenshot of the README's quick
start: it is kept in ``tests/artifacts/demo-dashboard.png``, and written to
``docs/img/dashboard.png`` when the environment has ``SONDALOG_DOCS_IMG=1``.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import pytest
from demo_process import DemoProcess

CHROMIUM = "/usr/bin/chromium"
ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "tests" / "artifacts"

if not os.path.exists(CHROMIUM):
    pytest.skip(f"{CHROMIUM} is not installed (Debian package chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api")


def test_the_demo_dashboard_in_chromium(tmp_path: Path) -> None:
    with DemoProcess(tmp_path) as demo, sync_api.sync_playwright() as p:
        demo.wait_for("Serving until Ctrl-C.")
        web = demo.url("Dashboard:  ", r"http://127\.0\.0\.1:\d+/")
        browser = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=[
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--no-first-run",
            ],
        )
        try:
            page = browser.new_page(viewport={"width": 1100, "height": 760})
            errors: list[str] = []
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.on(
                "console",
                lambda m: (
                    errors.append(m.text) if m.type == "error" and "favicon" not in m.text else None
                ),
            )
            page.goto(web)
            # every logger and module gets its card once the collector's first contacts are in
            for title in ("CABLE-01", "RAIN-02", "bus:T1", "bus:H1"):
                page.wait_for_selector(f"section.card h2 >> text={title}", timeout=30_000)
            assert page.locator("section.card.trouble").count() == 0

            page.goto(web + "loggers/RAIN-02")
            page.wait_for_selector("#plot[data-state=ready][data-live=connected]", timeout=20_000)
            got: dict[str, Any] = json.loads(
                page.evaluate(
                    "() => { const p = window.__plots['RAIN-02']; return JSON.stringify("
                    "{kinds: p.kinds, names: p.names, points: p.points}); }"
                )
            )
            assert got["kinds"] == ["line", "line", "bars", "line", "line"]
            assert got["names"][:3] == ["Supply [V]", "Air [C]", "Rain [imp]"]
            assert min(got["points"][:3]) >= 1000  # a week of 5-minute rows, downsampled
            # module time runs 60x: a new 5-minute row arrives live within seconds
            page.wait_for_function("() => window.__plots['RAIN-02'].liveRows > 0", timeout=30_000)
            # the picture shows the weather: hide the supply and the modem's channels
            for label in ("1: Supply [V]", "4: Signal", "5: Credit [CZK]"):
                page.get_by_label(label).uncheck()
            ARTIFACTS.mkdir(exist_ok=True)
            shot = ARTIFACTS / "demo-dashboard.png"
            page.screenshot(path=str(shot))
            if os.environ.get("SONDALOG_DOCS_IMG") == "1":
                shutil.copyfile(shot, ROOT / "docs" / "img" / "dashboard.png")
            assert errors == []
        finally:
            browser.close()
