"""What a field engineer must be able to trust on the dashboard (issue 26), in chromium:
a live plot equal to a fresh load, a lone reading drawn, downsampled points where readings
are, one time convention, values in the channel's format, one axis per unit."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from web_store import Running, execute, insert, make_store, series_rows

from sondalog.web import create_app
from sondalog.web.times import to_epoch

CHROMIUM = "/usr/bin/chromium"
if not os.path.exists(CHROMIUM):
    pytest.skip(f"{CHROMIUM} is not installed (Debian package chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--no-sandbox", "--disable-gpu", "--disable-background-networking"],
        )
        yield b
        b.close()


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[Path, Running]]:
    path = make_store(tmp_path / "store.sqlite")
    running = Running(create_app(path, poll_interval=0.2, max_points=400))
    yield path, running
    running.stop()


def _ready(page: Any, url: str, live: bool = False) -> None:
    page.goto(url)
    page.wait_for_selector("#plot[data-state=ready]" + ("[data-live=connected]" if live else ""))


def _data(page: Any, logger: str) -> Any:
    """The plot's joined data as uPlot holds it (undefined kept apart from null)."""
    return json.loads(
        page.evaluate(
            "(lg) => JSON.stringify(window.__plots[lg].uplot.data.map((a) => "
            "Array.from(a, (v) => (v === undefined ? 'undefined' : v))))",
            logger,
        )
    )


def test_a_live_update_across_a_pause_equals_a_fresh_load(
    browser: Any, served: tuple[Path, Running]
) -> None:
    path, running = served
    insert(path, series_rows("L", 1, "2026-03-01T00:00:00", 600, 30, name="T", unit="C"))
    page = browser.new_page()
    _ready(page, running.url + "/loggers/L", live=True)
    # 5 hours of nothing, then readings again every 10 minutes
    insert(path, series_rows("L", 1, "2026-03-01T09:50:00", 600, 2, name="T", unit="C", value=9))
    page.wait_for_selector("#plot[data-live-rows='2']", timeout=10_000)
    live = _data(page, "L")
    assert None in live[1]  # the pause is a gap, not a straight line
    _ready(page, running.url + "/loggers/L")
    assert _data(page, "L") == live
    page.close()


def test_a_lone_reading_between_two_gaps_is_drawn(
    browser: Any, served: tuple[Path, Running]
) -> None:
    path, running = served
    rows = list(series_rows("L", 1, "2026-03-01T00:00:00", 60, 300, name="T", unit="C"))
    rows.append(("L", 1, "2026-03-01T08:00:00", 0, 1, 10.0, None, "T", "C"))  # alone
    rows += series_rows("L", 1, "2026-03-01T11:00:00", 60, 90, name="T", unit="C")
    insert(path, rows)
    page = browser.new_page(viewport={"width": 1000, "height": 700})
    _ready(page, running.url + "/loggers/L")
    # the series' colour (#0b57d0) around where the lone reading is
    painted = page.evaluate(
        """([t, v]) => {
          const u = window.__plots['L'].uplot;
          const x = Math.round(u.valToPos(t, 'x', true)), y = Math.round(u.valToPos(v, 'u0', true));
          const d = u.ctx.getImageData(x - 4, y - 4, 9, 9).data;
          let n = 0;
          for (let i = 0; i < d.length; i += 4) {
            if (d[i + 2] > 150 && d[i] < 120 && d[i + 3] > 100) n++;
          }
          return n;
        }""",
        [to_epoch("2026-03-01T08:00:00"), 10.0],
    )
    assert painted >= 9
    page.close()


def test_downsampled_points_stay_where_readings_are(
    browser: Any, served: tuple[Path, Running]
) -> None:
    path, running = served
    rows = list(series_rows("L", 1, "2026-03-01T00:00:00", 60, 3000, name="T", unit="C"))
    insert(path, rows)
    page = browser.new_page()
    _ready(page, running.url + "/loggers/L?from=2026-03-01T00:00:00&to=2026-03-03T01:59:00")
    assert page.evaluate("window.__plots['L'].downsampled")
    xs, ys = _data(page, "L")
    readings = {to_epoch(r[2]): r[5] for r in rows}
    shown = [(x, y) for x, y in zip(xs, ys, strict=True) if y is not None]
    assert all(readings.get(x) == y for x, y in shown)  # real times and values
    assert shown[-1] == (to_epoch("2026-03-03T01:59:00"), rows[-1][5])  # the last reading
    page.close()


def test_one_time_convention_marked_and_the_clock_offset(
    browser: Any, served: tuple[Path, Running]
) -> None:
    path, running = served
    insert(path, series_rows("L", 1, "2026-03-01T00:00:00", 600, 144, name="T", unit="C"))
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_contact, offset_s) VALUES "
        "('f', 'tcp://127.0.0.1:1', 'logger', 'L', 'ok', '2026-03-02T00:51:00+01:00', -3295)",
    )
    page = browser.new_page()
    page.goto(running.url + "/")
    facts = page.locator("dl.facts").inner_text()
    assert "Last reading (logger clock)\n2026-03-01 23:50:00" in facts
    assert "Last contact (this computer)\n2026-03-02 00:51:00 UTC+01:00" in facts
    assert "Logger clock\n3295 s (55 min) behind this computer" in facts
    assert "2026-03-01 23:50:00" in page.locator("tbody td").last.inner_text()

    _ready(page, running.url + "/loggers/L", live=True)
    assert page.get_by_label("From (logger clock)").input_value() == "2026-03-01 00:00:00"
    assert page.get_by_label("To (logger clock)").input_value() == "2026-03-01 23:50:00"
    # in live mode To follows the last reading
    insert(path, [("L", 1, "2026-03-02T00:00:00", 0, 1, 5.0, None, "T", "C")])
    page.wait_for_selector("#plot[data-live-rows='1']", timeout=10_000)
    assert page.get_by_label("To (logger clock)").input_value() == "2026-03-02 00:00:00"
    # a range typed the way it is shown
    page.get_by_label("From (logger clock)").fill("2026-03-01 06:00:00")
    page.get_by_label("To (logger clock)").fill("2026-03-01 12:00:00")
    page.get_by_label("To (logger clock)").press("Enter")
    page.wait_for_url("**/loggers/L?from=*")
    page.wait_for_selector("#plot[data-state=ready]")
    got = page.evaluate("[window.__plots['L'].from, window.__plots['L'].to]")
    assert got == ["2026-03-01T06:00:00", "2026-03-01T12:00:00"]
    page.close()


def test_values_in_the_channel_format_and_the_live_checkbox_beside_its_label(
    browser: Any, served: tuple[Path, Running]
) -> None:
    path, running = served
    insert(
        path,
        series_rows(
            "L", 1, "2026-03-01T00:00:00", 600, 10, name="T", unit="C", value=20, slope=0.5
        ),
    )
    page = browser.new_page()
    page.goto(running.url + "/")
    assert page.locator("tbody td.num").inner_text() == "24.5"
    execute(path, "UPDATE readings SET value = 25.0 WHERE time = '2026-03-01T01:30:00'")
    page.goto(running.url + "/")
    assert page.locator("tbody td.num").inner_text() == "25.0"  # as the logger wrote it
    _ready(page, running.url + "/loggers/L")
    assert page.evaluate("window.__plots['L'].uplot.series[1].value(null, 0)") == "0.0"
    box = page.locator("#live").bounding_box()
    text = page.locator("label[for=live]").bounding_box()
    assert box is not None and text is not None
    assert text["x"] > box["x"] + box["width"] - 1  # beside it, not below
    middle = box["y"] + box["height"] / 2
    assert text["y"] <= middle <= text["y"] + text["height"]
    page.close()


def test_one_axis_per_unit_and_per_channel_without_one(
    browser: Any, served: tuple[Path, Running]
) -> None:
    """A logger known only from its messages has no units: its credit of 250 must not
    flatten the supply of 12 V on a shared axis."""
    path, running = served
    start = "2026-03-01T00:00:00"
    rows = list(series_rows("G", 1, start, 900, 50, name=None, unit=None, value=12))  # type: ignore[arg-type]
    rows += series_rows("G", 2, start, 900, 50, name=None, unit=None, value=8)  # type: ignore[arg-type]
    rows += series_rows("G", 3, start, 900, 50, name="Air", unit="C", value=5)
    rows += series_rows("G", 4, start, 900, 50, name="Water", unit="C", value=4)
    rows += series_rows("G", 5, start, 900, 50, name=None, unit=None, value=250, slope=0)  # type: ignore[arg-type]
    insert(path, rows)
    page = browser.new_page()
    _ready(page, running.url + "/loggers/G")
    scales = page.evaluate("window.__plots['G'].uplot.series.slice(1).map((s) => s.scale)")
    assert len(set(scales)) == 4  # 3 channels without a unit, and C
    assert scales[2] == scales[3]
    assert page.locator("#plot .u-axis").count() == 5  # x and the 4 y axes
    page.close()
