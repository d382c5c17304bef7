"""The dashboard shows the collector's alarms and asks for acknowledgements (issue 21).

A real store file with the alarms written through AlarmStore (save_states, record), served
by a real uvicorn; the acknowledgement lands in ``alarm_acks`` for the collector.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

import pytest
from alarm_store import HOT, QUIET, STEP, acks, add_alarms, post_ack, request
from test_web_escaping import ATTR, SCRIPT, assert_inert
from web_store import Running

from sondalog.collect.alarms import AlarmStore
from sondalog.web import create_app

TOKEN = "s3cret-token-123"


@pytest.fixture
def alarmed(store: Path) -> Iterator[Running]:
    add_alarms(store)
    running = Running(create_app(store, poll_interval=0.2, overview_refresh=0.3))
    yield running
    running.stop()


def html(url: str) -> str:
    status, _, body = request(url)
    assert status == 200, body
    return body.decode()


def test_api_lists_active_alarms_and_history(alarmed: Running) -> None:
    status, _, body = request(alarmed.url + "/api/alarms")
    assert status == 200
    data = json.loads(body)
    on = {a["id"]: a for a in data["active"]}
    assert list(on) == [HOT, QUIET]  # newest raise first; the cleared one is not active
    hot = on[HOT]
    assert (hot["rule"], hot["subject"], hot["logger"], hot["state"]) == (
        "Temp high",
        "1001/1",
        "1001",
        "raised",
    )
    assert hot["value"] == 42.5 and hot["since"] == pytest.approx(1772326800.0)
    assert hot["since_time"].startswith("2026-03-01T") and not hot["ack_requested"]
    assert on[QUIET]["logger"] == "bus:M1"  # the source "bus" belongs to the module
    assert on[QUIET]["state"] == "acknowledged"
    history = [(h["id"], h["what"]) for h in data["history"]]
    assert history == [
        (HOT, "raised"),
        (STEP, "cleared"),
        (STEP, "raised"),
        (QUIET, "acknowledged"),
        (QUIET, "raised"),
    ]
    mine = json.loads(request(alarmed.url + "/api/alarms?logger=1001")[2])
    assert [a["id"] for a in mine["active"]] == [HOT]
    assert {h["id"] for h in mine["history"]} == {HOT, STEP}


def test_pages_show_alarms(alarmed: Running) -> None:
    page = html(alarmed.url + "/")
    assert '<a id="alarm-count"' in page and "2 active alarms" in page
    assert "Active alarms (2)" in page
    assert "Temp high" in page and "no contact bus" in page and "1001/1 above 40: 42.5" in page
    assert page.count('<form class="ack"') == 1  # only the raised one can be acknowledged
    assert f'action="/api/alarms/{HOT}/ack"' in page
    assert "Level step" not in page  # cleared: history only

    logger = html(alarmed.url + "/loggers/1001")
    assert "Temp high" in logger and "no contact bus" not in logger
    assert "2 active alarms" in logger  # the header counts every alarm
    module = html(alarmed.url + "/loggers/bus%3AM1")
    assert "no contact bus" in module and "Temp high" not in module

    log = html(alarmed.url + "/log")
    assert "Alarm history" in log
    for text in ("1001/2 calm again", "bus: acknowledged by anna", "1001/1 above 40: 42.5"):
        assert text in log
    assert log.index("1001/1 above 40") < log.index("1001/2 calm again")  # newest first
    assert "message 119" in log  # the events are still there


def test_a_store_without_alarm_tables_has_no_alarms(server: Running) -> None:
    status, _, body = request(server.url + "/api/alarms")
    assert status == 200 and json.loads(body) == {"active": [], "history": []}
    assert "0 active alarms" in html(server.url + "/")
    assert "No alarm has been raised." in html(server.url + "/log")
    status, answer = post_ack(server.url, HOT)
    assert status == 404 and answer == {"error": f"unknown alarm {HOT!r}"}


def test_ack_without_token_is_stored_for_the_collector(alarmed: Running, store: Path) -> None:
    status, answer = post_ack(alarmed.url, HOT)
    assert status == 202, answer
    assert answer["alarm"] == HOT and answer["ack_requested"] and answer["by"] == "dashboard"
    [(alarm, by, _, done)] = acks(store)
    assert (alarm, by, done) == (HOT, "dashboard", None)
    page = html(alarmed.url + "/")
    assert "ack requested" in page and '<form class="ack"' not in page

    # the collector takes it on its next turn
    with AlarmStore(store) as alarm_store:
        assert [(a, b) for a, b, _ in alarm_store.take_ack_requests(1.0)] == [(HOT, "dashboard")]

    status, answer = post_ack(alarmed.url, HOT, body=json.dumps({"by": "anna"}).encode())
    assert status == 202 and answer["by"] == "anna"
    status, answer = post_ack(alarmed.url, HOT, body=b'{"by": 5}')
    assert status == 400 and "body.by" in answer["error"]


def test_ack_of_unknown_or_not_raised_alarm(alarmed: Running, store: Path) -> None:
    status, answer = post_ack(alarmed.url, "0123456789")
    assert status == 404 and answer == {"error": "unknown alarm '0123456789'"}
    status, answer = post_ack(alarmed.url, QUIET)
    assert status == 409 and answer["state"] == "acknowledged"
    assert "only a raised alarm can be acknowledged" in answer["error"]
    status, answer = post_ack(alarmed.url, STEP)
    assert status == 409 and answer["state"] == "cleared"
    assert acks(store) == []


def test_cross_site_post_is_refused(alarmed: Running, store: Path) -> None:
    base = alarmed.url
    host = urlsplit(base).netloc
    evil = "http://evil.example"
    for headers in (
        {},  # a POST that does not say where it comes from
        {"Origin": evil},
        {"Origin": "null"},
        {"Referer": evil + "/page"},
        {"Origin": evil, "Referer": base + "/"},  # Origin wins
        {"Origin": "http://127.0.0.1:1"},  # another port is another site
        # DNS rebinding: evil.example made to point at 127.0.0.1
        {"Host": "evil.example:" + host.split(":")[1], "Origin": "http://evil.example:1"},
        {"Host": "evil.example:" + host.split(":")[1], "Origin": "http://evil.example:"
         + host.split(":")[1]},
    ):  # fmt: skip
        status, answer = post_ack(base, HOT, headers)
        assert status == 403, (headers, answer)
        assert "error" in answer
    assert acks(store) == []
    # the dashboard's own page: Origin, or only a Referer of this host
    assert post_ack(base, HOT, {"Referer": base + "/loggers/1001"})[0] == 202
    assert len(acks(store)) == 1


def test_ack_button_without_javascript_returns_to_the_page(alarmed: Running, store: Path) -> None:
    status, headers, _ = request(
        f"{alarmed.url}/api/alarms/{HOT}/ack",
        method="POST",
        body=b"",
        headers={
            "Origin": alarmed.url,
            "Referer": alarmed.url + "/loggers/1001?from=2026-03-01",
            "Content-Type": "application/x-www-form-urlencoded",
            "Accept": "text/html,application/xhtml+xml,*/*;q=0.8",
        },
    )
    assert status == 303 and headers["location"] == "/loggers/1001?from=2026-03-01"
    assert [a[0] for a in acks(store)] == [HOT]


def test_ack_with_token(store: Path) -> None:
    add_alarms(store)
    running = Running(create_app(store, token=TOKEN))
    try:
        url = running.url
        status, _, _ = request(f"{url}/api/alarms/{HOT}/ack", method="POST", body=b"")
        assert status == 401
        status, _, _ = request(
            f"{url}/api/alarms/{HOT}/ack", method="POST", body=b"", headers={"Origin": url}
        )
        assert status == 401  # same origin is not enough: the token is needed
        bearer = {"Authorization": f"Bearer {TOKEN}"}
        assert post_ack(url, HOT, {**bearer, "Origin": "http://evil.example"})[0] == 403
        assert acks(store) == []
        status, answer = post_ack(url, HOT, bearer)  # a script: the token is the proof
        assert status == 202, answer
        status, answer = post_ack(url, HOT, {"Cookie": f"sondalog_token={TOKEN}", "Origin": url})
        assert status == 202, answer
        assert [a[0] for a in acks(store)] == [HOT, HOT]
        status, _, body = request(f"{url}/api/alarms", headers=bearer)
        assert status == 200 and json.loads(body)["active"][0]["ack_requested"]
    finally:
        running.stop()


def test_alarm_names_and_texts_are_escaped(store: Path) -> None:
    add_alarms(store, hot_rule=SCRIPT + ATTR, hot_text=ATTR + SCRIPT)
    running = Running(create_app(store))
    try:
        for path in ("/", "/loggers/1001", "/log"):
            assert_inert(html(running.url + path), [SCRIPT + ATTR, ATTR + SCRIPT])
    finally:
        running.stop()


def test_an_alarm_server_that_cannot_be_reached(store: Path) -> None:
    """``[postgres] alarms = true`` with the server down: ``/api/alarms`` and the POST answer
    503 (naming no DSN: it may hold a password), the pages still show the readings."""
    from sondalog.collect.alarms.store_pg import PostgresAlarmStore

    with socket.socket() as sock:  # a port nobody listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    down = PostgresAlarmStore(f"host=127.0.0.1 port={port} user=secret-user", connect_timeout=1)
    running = Running(create_app(store, alarm_store=down))
    try:
        status, _, body = request(running.url + "/api/alarms")
        assert status == 503, body
        error = json.loads(body)["error"]
        assert "the alarms on the [postgres] server cannot be read" in error
        assert "secret-user" not in error
        assert post_ack(running.url, HOT)[0] == 503
        assert "1001" in html(running.url + "/")  # the readings are still there
        assert html(running.url + "/loggers/1001") and html(running.url + "/log")
    finally:
        running.stop()


def test_pages_say_alarms_are_unavailable_not_that_there_are_none(store: Path) -> None:
    """With the alarm server down no page says "No active alarms" (or "0 active alarms",
    "No alarm has been raised"): each says the alarms are unavailable, naming no DSN; once
    the store can be read again the pages say there are none."""
    from sondalog.collect.alarms.store_pg import PostgresAlarmStore

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    down = PostgresAlarmStore(f"host=127.0.0.1 port={port} user=secret-user", connect_timeout=1)
    running = Running(create_app(store, alarm_store=down))
    try:
        for path in ("/", "/loggers/1001", "/log"):
            page = html(running.url + path)
            assert "Alarms unavailable:" in page, path
            assert "the alarms on the [postgres] server cannot be read now" in page
            assert ">alarms unavailable</a>" in page  # the header's count
            assert "No active alarms" not in page and "0 active alarms" not in page
            assert "No alarm has been raised" not in page and "secret-user" not in page
    finally:
        running.stop()
    running = Running(create_app(store))  # the file's alarm tables: readable, none there
    try:
        assert "No active alarms" in html(running.url + "/")
        assert "No alarm has been raised" in html(running.url + "/log")
        assert "unavailable" not in html(running.url + "/loggers/1001")
    finally:
        running.stop()
