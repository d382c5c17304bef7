"""The Acknowledge button in a real browser (Debian's chromium driven by playwright): a click
stores the request in ``alarm_acks`` and shows "ack requested"; the collector's answer
(the alarm acknowledged) then appears on the logger's page without a reload (issue 21)."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from alarm_store import HOT, acks, add_alarms
from web_store import Running

from sondalog.collect.alarms import AlarmStore
from sondalog.web import create_app

CHROMIUM = shutil.which("chromium")

if CHROMIUM is None:
    pytest.skip("chromium is not installed (Debian package chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--no-sandbox", "--disable-gpu", "--no-first-run"],
        )
        yield b
        b.close()


@pytest.fixture
def alarmed(store: Path) -> Iterator[Running]:
    add_alarms(store)
    running = Running(create_app(store, poll_interval=0.2, overview_refresh=0.5))
    yield running
    running.stop()


def test_ack_button_records_the_request(browser: Any, alarmed: Running, store: Path) -> None:
    page = browser.new_page(viewport={"width": 1000, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.goto(alarmed.url + "/")
    assert page.locator("#alarm-count").inner_text() == "2 active alarms"
    rows = page.locator("#alarms tbody tr")
    assert rows.count() == 2
    button = page.get_by_role("button", name="Acknowledge Temp high on 1001/1")
    assert acks(store) == []
    button.click()
    page.wait_for_selector("#alarms >> text=ack requested", timeout=5000)
    assert page.get_by_role("button", name="Acknowledge Temp high on 1001/1").count() == 0
    [(alarm, by, _, done)] = acks(store)
    assert (alarm, by, done) == (HOT, "dashboard", None)
    # the overview's own refresh keeps it: the dashboard knows the request waits
    page.wait_for_function("Number(document.getElementById('main').dataset.refreshed) >= 2")
    assert "ack requested" in page.locator("#alarms").inner_text()

    # the logger's page, then the collector applies the request: shown without a reload
    page.goto(alarmed.url + "/loggers/1001")
    assert "ack requested" in page.locator("#alarms").inner_text()
    with AlarmStore(store) as alarm_store:
        [(_, _, requested)] = alarm_store.take_ack_requests(1.0e9)
        [hot] = [r for r in alarm_store.load_states() if r.alarm == HOT]
        alarm_store.save_states(
            [replace(hot, state="acknowledged", since=requested, acked_at=requested)]
        )
    page.wait_for_selector("#alarms >> text=acknowledged 20", timeout=5000)
    assert "ack requested" not in page.locator("#alarms").inner_text()
    assert errors == []
    page.close()
