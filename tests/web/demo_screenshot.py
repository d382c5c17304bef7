"""Make ``docs/img/dashboard.png``: a plausible store, the dashboard, chromium's screenshot.

Run: ``.venv/bin/python tests/web/demo_screenshot.py [OUT.png]`` (needs /usr/bin/chromium).
Three weeks of a field logger (air temperature, relative humidity, rain pulses as a type-6
event channel) reported every 10 minutes; the plot shows its last week.
"""

from __future__ import annotations

import math
import random
import sys
import tempfile
from datetime import datetime, timedelta
from pathlib import Path

from playwright.sync_api import sync_playwright
from web_store import CHANNELS_DDL, Running, execute, insert, make_store

from sondalog.web import create_app


def fill(path: Path) -> None:
    make_store(path)
    execute(path, CHANNELS_DDL)
    rnd = random.Random(14)
    t0 = datetime(2026, 5, 1)
    rows = []
    weather = 0.0
    for i in range(21 * 144):
        t = t0 + timedelta(minutes=10 * i)
        stamp = t.strftime("%Y-%m-%dT%H:%M:%S")
        day = math.sin(2 * math.pi * (i % 144 - 54) / 144)
        weather += rnd.gauss(0, 0.08) - weather * 0.01
        if 1500 <= i < 1530:  # the sensor was disconnected for five hours: a gap
            continue
        temp = round(14 + 6 * day + 3 * weather + rnd.gauss(0, 0.15), 2)
        rh = round(min(100.0, 70 - 18 * day - 6 * weather + rnd.gauss(0, 0.8)), 1)
        rows.append(("21040117", 1, stamp, 0, 1, temp, None, "Air", "°C"))
        rows.append(("21040117", 2, stamp, 0, 1, rh, None, "RH", "%"))
        if weather < -0.25 and rnd.random() < 0.5:
            rows.append(
                ("21040117", 3, stamp, 0, 1, float(rnd.randint(1, 12)), None, "Rain", "imp")
            )
        if i % 6 == 0:
            rows.append(("bus:HC1", 1, stamp, 0, 1, round(temp + 4.5, 2), None, "Soil", "°C"))
    insert(path, rows)
    execute(path, "INSERT INTO channels VALUES ('21040117', 3, 'Rain', 'imp', 6)")
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_contact, "
        "record_fill, signal, credit) VALUES ('field', 'mailbox://pop3.example/field', "
        "'mailbox', '21040117', 'ok', ?, '88120,0.08,CLEAR', 21, 184.5)",
        (stamp,),
    )
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_error) VALUES "
        "('soil', 'bus://127.0.0.1:5020', 'bus', 'bus:HC1', 'offline', "
        "'no answer from HC1 (3 tries)')",
    )


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/img/dashboard.png")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "store.sqlite"
        fill(path)
        running = Running(create_app(path))
        try:
            with sync_playwright() as p:
                b = p.chromium.launch(
                    executable_path="/usr/bin/chromium",
                    headless=True,
                    args=["--no-sandbox", "--disable-gpu", "--no-first-run"],
                )
                page = b.new_page(viewport={"width": 1100, "height": 760})
                page.goto(running.url + "/loggers/21040117?from=2026-05-15T00:00:00")
                page.wait_for_selector("#plot[data-state=ready]")
                out.parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(out))
                page.goto(running.url + "/")
                page.screenshot(path=str(out.with_name(out.stem + "-overview.png")), full_page=True)
                b.close()
        finally:
            running.stop()
    print(out)


if __name__ == "__main__":
    main()
