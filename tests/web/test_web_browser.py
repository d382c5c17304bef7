"""The dashboard in a real browser: Debian's chromium driven by playwright (never downloaded)."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from web_store import Running, execute, insert

CHROMIUM = "/usr/bin/chromium"
ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"

if not os.path.exists(CHROMIUM):
    pytest.skip(f"{CHROMIUM} is not installed (Debian package chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(
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
        yield b
        b.close()


class Console:
    """Errors the page reported (the favicon is filtered by text)."""

    def __init__(self, page: Any) -> None:
        self.errors: list[str] = []
        page.on("console", self._console)
        page.on("pageerror", lambda exc: self.errors.append(f"pageerror: {exc}"))

    def _console(self, msg: Any) -> None:
        if msg.type == "error" and "favicon" not in msg.text:
            self.errors.append(msg.text)


def plots(page: Any) -> dict[str, Any]:
    got = page.evaluate(
        "() => { const p = window.__plots['1001']; return JSON.stringify({series: p.series, "
        "points: p.points, kinds: p.kinds, names: p.names, from: p.from, to: p.to, "
        "live: p.liveRows}); }"
    )
    return json.loads(got)  # type: ignore[no-any-return]


def test_overview_and_log_pages(browser: Any, server: Running, store: Path) -> None:
    page = browser.new_page(viewport={"width": 390, "height": 844})  # a phone
    console = Console(page)
    page.goto(server.url + "/")
    assert page.locator("section.card.trouble h2").inner_text().startswith("Module bus:M1")
    assert page.locator("section.card").count() == 2
    # keyboard: the skip link comes first, then the navigation
    page.keyboard.press("Tab")
    assert page.evaluate("document.activeElement.textContent") == "Skip to content"
    # no horizontal scrolling of the page itself on a phone
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")
    # the overview refreshes itself: a source falling into trouble shows up
    execute(
        store, "UPDATE sources SET state = 'offline', last_error = 'timeout' WHERE name = 'field'"
    )
    page.locator("body").click(position={"x": 5, "y": 5})  # focus out of <main>
    page.wait_for_selector("section.card.trouble >> text=timeout", timeout=5000)
    assert page.locator("section.card.trouble").count() == 2
    page.get_by_role("link", name="Log").click()
    page.wait_for_url("**/log")
    assert page.locator("tbody tr").count() == 50
    page.get_by_role("link", name="Older").click()
    assert page.locator("tbody tr").first.inner_text().split("\t")[-1] == "message 69"
    page.get_by_label("Source").fill("nobody")
    page.get_by_label("Source").press("Enter")
    page.wait_for_url("**/log?source=nobody")
    assert "No events." in page.content()
    ARTIFACTS.mkdir(exist_ok=True)
    page.goto(server.url + "/")
    page.screenshot(path=str(ARTIFACTS / "overview-phone.png"), full_page=True)
    assert console.errors == []
    page.close()


def test_plot_live_and_range_selection(browser: Any, server: Running, store: Path) -> None:
    page = browser.new_page(viewport={"width": 1100, "height": 800})
    console = Console(page)
    page.goto(server.url + "/loggers/1001")
    page.wait_for_selector("#plot[data-state=ready][data-live=connected]")
    got = plots(page)
    assert got["series"] == 3
    assert got["points"] == [144, 144, 8]
    assert got["kinds"] == ["line", "line", "bars"]
    assert got["names"] == ["Temp [°C]", "Level [cm]", "Rain [imp]"]
    assert page.locator("#plot .u-series").count() == 4  # the x legend entry and 3 series
    assert page.get_by_label("From").input_value() == "2026-03-01 00:00:00"
    csv = page.get_by_role("link", name="Download CSV of this range").get_attribute("href")
    assert csv is not None and "readings.csv?from=2026-03-01T00%3A00%3A00" in csv

    # a new reading in the store shows up live
    insert(store, [("1001", 1, "2026-03-02T00:00:00", 0, 1, 99.5, None, "Temp", "°C")])
    page.wait_for_selector("#plot[data-live-rows='1']", timeout=10_000)
    assert plots(page)["points"] == [145, 144, 8]
    assert plots(page)["to"] == "2026-03-02T00:00:00"
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / "dashboard.png"), full_page=True)

    # dragging across the plot selects a range, which is loaded from the server
    box = page.locator("#plot .u-over").bounding_box()
    assert box is not None
    y = box["y"] + box["height"] / 2
    page.mouse.move(box["x"] + box["width"] * 0.90, y)
    page.mouse.down()
    page.mouse.move(box["x"] + box["width"] * 0.95, y, steps=5)
    page.mouse.up()
    page.wait_for_url("**/loggers/1001?from=*")
    page.wait_for_selector("#plot[data-state=ready]")
    got = plots(page)
    assert got["from"] > "2026-03-01T00:00:00" and got["to"] < "2026-03-02T00:00:00"
    assert 0 < got["points"][0] < 144
    assert page.locator("#plot").get_attribute("data-live") is None  # a fixed range
    # a channel can be hidden with its (keyboard-usable) checkbox
    page.get_by_label("2: Level [cm]").focus()
    page.keyboard.press("Space")
    assert page.evaluate("window.__plots['1001'].uplot.series[2].show") is False
    page.get_by_label("2: Level [cm]").check()
    assert page.evaluate("window.__plots['1001'].uplot.series[2].show") is True
    # the keyboard path: presets are buttons
    page.get_by_role("button", name="Last day").focus()
    page.keyboard.press("Enter")
    page.wait_for_url("**/loggers/1001?from=2026-03-01T00*")
    page.wait_for_selector("#plot[data-state=ready][data-live=connected]")
    assert plots(page)["points"][1] == 144
    page.go_back()
    page.wait_for_selector("#plot[data-state=ready]")
    assert plots(page)["to"] < "2026-03-02T00:00:00"
    # readable on a phone: nothing wider than the screen
    page.set_viewport_size({"width": 390, "height": 844})
    page.reload()
    page.wait_for_selector("#plot[data-state=ready]")
    assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")
    assert console.errors == []
    page.close()
