"""Hostile names in the store come out escaped on every page (issue 25 item 6: the pages
are Jinja2 templates with autoescape on), served by a real uvicorn from a real store.

A name is shown as text, never markup: no page gains a script without ``src`` or an
``on…`` attribute, whatever the loggers, channels, units, sources and log say.
"""

from __future__ import annotations

import urllib.error
import urllib.request
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import quote, urlencode

import pytest
from web_store import Running, execute, insert, make_store, series_rows

from sondalog.web import create_app

SCRIPT = "<script>alert(1)</script>"
#: Breaks out of a quoted attribute (``id="h-…"``, ``value="…"``) when not escaped.
ATTR = '"onmouseover="alert(2)'
#: A logger name for a page of its own: the route takes no '/', so no ``</script>``.
LOGGER_TAG = "<img src=x onerror=alert(3)>"


class Page(HTMLParser):
    """What a browser would build: tags with their attributes, and the text shown."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def parse(html: str) -> Page:
    page = Page()
    page.feed(html)
    page.close()
    return page


def assert_inert(html: str, shown: list[str]) -> None:
    """No markup from the store, and each hostile name shown as text or attribute value."""
    page = parse(html)
    for tag, attrs in page.tags:
        assert tag != "img", f"an <img> from the store: {attrs}"
        assert not [a for a in attrs if a.startswith("on")], f"an event handler: {tag} {attrs}"
        if tag == "script":
            assert (attrs.get("src") or "").startswith("/static/"), f"an inline script: {attrs}"
    text = "".join(page.text)
    values = [v for _, attrs in page.tags for v in attrs.values() if v]
    for name in shown:
        assert name in text or name in values, f"{name!r} is not shown on the page"


def get(url: str) -> tuple[int, str]:
    try:
        with urllib.request.urlopen(url, timeout=10) as resp:
            return resp.status, resp.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode()


@pytest.fixture
def hostile(tmp_path: Path) -> Iterator[Running]:
    path = make_store(tmp_path / "store.sqlite")
    start = "2026-03-01T00:00:00"
    rows = list(series_rows(LOGGER_TAG, 1, start, 600, 3, name=SCRIPT, unit=ATTR))
    rows += series_rows(ATTR, 2, start, 600, 3, name=ATTR, unit=SCRIPT)
    insert(path, rows)
    execute(
        path,
        "INSERT INTO sources (name, url, kind, logger, state, last_contact, last_error) "
        "VALUES (?, ?, 'logger', ?, 'offline', '2026-03-01T10:00:00+00:00', ?)",
        (SCRIPT, ATTR, LOGGER_TAG, SCRIPT),
    )
    execute(
        path,
        "INSERT INTO sources (name, url, kind, state, last_contact) "
        "VALUES (?, ?, 'logger', 'new', ?)",
        (ATTR, SCRIPT, SCRIPT),
    )
    execute(
        path,
        "INSERT INTO events (time, source, kind, text) VALUES (?, ?, ?, ?)",
        (SCRIPT, ATTR, SCRIPT, ATTR + SCRIPT),
    )
    running = Running(create_app(path, poll_interval=0.2))
    yield running
    running.stop()


def test_hostile_names_are_escaped_on_every_page(hostile: Running) -> None:
    status, html = get(hostile.url + "/")
    assert status == 200
    assert_inert(html, [SCRIPT, ATTR, LOGGER_TAG])

    for logger, channel in ((LOGGER_TAG, SCRIPT), (ATTR, ATTR)):
        status, html = get(hostile.url + "/loggers/" + quote(logger, safe=""))
        assert status == 200, html
        assert_inert(html, [logger, channel])

    status, html = get(hostile.url + "/log")
    assert status == 200
    assert_inert(html, [SCRIPT, ATTR, ATTR + SCRIPT])

    status, html = get(hostile.url + "/log?" + urlencode({"source": ATTR}))
    assert status == 200
    assert_inert(html, [ATTR, ATTR + SCRIPT])

    status, html = get(hostile.url + "/loggers/" + quote(SCRIPT.replace("/", ""), safe=""))
    assert status == 404
    assert_inert(html, [f"unknown logger {SCRIPT.replace('/', '')!r}"])
