"""The dashboard's JSON API, CSV and live stream against a real uvicorn and a real store."""

from __future__ import annotations

import http.client
import json
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from web_store import Running, execute, insert, make_store, series_rows

from sondalog.config import ConfigError
from sondalog.web import check_listen, create_app


def get(url: str, headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], bytes]:
    req = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=10) as resp:
            return resp.status, dict(resp.headers), resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def get_json(url: str) -> Any:
    status, _, body = get(url)
    assert status == 200, body
    return json.loads(body)


def test_overview_lists_loggers_modules_and_trouble(server: Running) -> None:
    data = get_json(server.url + "/api/loggers")
    by = {lg["logger"]: lg for lg in data["loggers"]}
    assert sorted(by) == ["1001", "bus:M1"]
    lg = by["1001"]
    assert [(c["channel"], c["name"], c["unit"], c["kind"]) for c in lg["channels"]] == [
        (1, "Temp", "°C", "line"),
        (2, "Level", "cm", "line"),
        (3, "Rain", "imp", "bars"),
    ]
    temp = lg["channels"][0]
    assert temp["time"] == "2026-03-01T23:50:00"
    assert temp["value"] == pytest.approx(20 + 0.1 * 143)
    assert (lg["record_fill"], lg["signal"], lg["credit"]) == ("1234,0.05,CLEAR", 17, 123.5)
    assert lg["last_contact"] == "2026-03-01T23:51:00"
    assert not lg["trouble"]
    assert by["bus:M1"]["trouble"] and by["bus:M1"]["module"]
    assert by["bus:M1"]["sources"][0]["last_error"] == "connection refused"

    status, _, body = get(server.url + "/")
    page = body.decode()
    assert status == 200
    assert 'class="card trouble"' in page and "connection refused" in page
    assert "Temp" in page and "°C" in page and "123.5" in page
    assert "5 % full (1,234 characters), CLEAR" in page
    assert 'href="/loggers/bus%3AM1"' in page


def test_series_raw_keeps_names_kinds_and_gaps(server: Running, store: Path) -> None:
    # a "no valid value" reading and a 4-hour pause in channel 1
    execute(
        store,
        "UPDATE readings SET value = NULL WHERE logger = '1001' AND channel = 1 "
        "AND time = '2026-03-01T01:00:00'",
    )
    execute(
        store,
        "DELETE FROM readings WHERE logger = '1001' AND channel = 1 "
        "AND time > '2026-03-01T12:00:00' AND time < '2026-03-01T16:00:00'",
    )
    d = get_json(server.url + "/api/loggers/1001/series?from=2026-03-01&to=2026-03-01T23:59:59")
    assert not d["downsampled"]
    assert [s["kind"] for s in d["series"]] == ["line", "line", "bars"]
    temp, level, rain = d["series"]
    assert (temp["name"], temp["unit"]) == ("Temp", "°C")
    assert len(level["v"]) == 144 and None not in level["v"]
    assert len(rain["t"]) == 8
    assert temp["v"][6] is None  # 01:00, the NULL reading
    # the pause: 144 - 23 deleted rows + the null + one null inserted in the pause
    assert len(temp["v"]) == 144 - 23 + 1
    i = temp["v"].index(None, 7)
    assert temp["t"][i - 1] < temp["t"][i] < temp["t"][i + 1]
    assert temp["t"][i + 1] - temp["t"][i - 1] == 4 * 3600
    assert d["x_from"] == 1772323200 and d["last"] == "2026-03-01T23:50:00"


def test_series_downsampled_min_max(tmp_path: Path) -> None:
    path = make_store(tmp_path / "big.sqlite")
    rows = list(series_rows("big", 1, "2026-01-01T00:00:00", 60, 3 * 1440, name="T", unit="K"))
    rows[2000] = (*rows[2000][:5], 1e6, *rows[2000][6:])  # a spike must survive
    insert(path, rows)
    running = Running(create_app(path, max_points=300))
    try:
        d = get_json(running.url + "/api/loggers/big/series?from=2026-01-01&to=2026-01-03T23:59:00")
        assert d["downsampled"] and d["bucket_s"] == 1728
        (s,) = d["series"]
        assert 250 <= len(s["v"]) <= 300
        assert max(v for v in s["v"] if v is not None) == 1e6
        assert min(v for v in s["v"] if v is not None) == 0.0
        assert s["t"] == sorted(s["t"])
        status, _, body = get(running.url + "/api/loggers/big/series?points=301")
        assert status == 400 and b"points" in body
    finally:
        running.stop()


@pytest.mark.parametrize(
    ("query", "needle"),
    [
        ("from=yesterday", "from: expected a time"),
        ("to=2026-13-01", "to: expected a time"),
        ("from=2026-03-02&to=2026-03-01", "is after to"),
        ("from=2026-03-01T00:00:00%2B01:00", "without a zone"),
        ("points=many", "points: expected a whole number"),
        ("points=1", "points: must be between"),
    ],
)
def test_bad_parameters_are_400(server: Running, query: str, needle: str) -> None:
    status, _, body = get(f"{server.url}/api/loggers/1001/series?{query}")
    assert status == 400
    assert needle in json.loads(body)["error"]


def test_unknown_logger_is_404(server: Running) -> None:
    for path in (
        "/api/loggers/nope",
        "/api/loggers/nope/series",
        "/api/loggers/nope/stream",
        "/api/loggers/nope/readings.csv",
        "/loggers/nope",
    ):
        status, _, body = get(server.url + path)
        assert status == 404, path
        assert b"unknown logger" in body and b"nope" in body


def test_csv_of_a_range(server: Running) -> None:
    url = server.url + "/api/loggers/1001/readings.csv?from=2026-03-01T04:30:00&to=2026-03-01T05:00"
    status, headers, body = get(url)
    assert status == 200 and headers["content-type"].startswith("text/csv")
    assert 'filename="1001.csv"' in headers["content-disposition"]
    lines = body.decode().splitlines()
    assert lines[0] == "logger,time,counter,type,channel,value,text,name,unit,utc"
    assert lines[1:] == [
        "1001,2026-03-01T04:30:00,0,1,1,22.7,,Temp,°C,",
        "1001,2026-03-01T04:30:00,0,1,2,94.6,,Level,cm,",
        "1001,2026-03-01T04:40:00,0,1,1,22.8,,Temp,°C,",
        "1001,2026-03-01T04:40:00,0,1,2,94.4,,Level,cm,",
        "1001,2026-03-01T04:50:00,0,1,1,22.9,,Temp,°C,",
        "1001,2026-03-01T04:50:00,0,1,2,94.2,,Level,cm,",
        "1001,2026-03-01T05:00:00,0,3,0,,door opened,,,",
        "1001,2026-03-01T05:00:00,0,1,1,23.0,,Temp,°C,",
        "1001,2026-03-01T05:00:00,0,1,2,94.0,,Level,cm,",
    ]
    _, _, whole = get(server.url + "/api/loggers/1001/readings.csv")
    assert len(whole.decode().splitlines()) == 1 + 144 * 2 + 8 + 1


def test_events_newest_first_paged(server: Running) -> None:
    first = get_json(server.url + "/api/events?limit=50")
    assert [e["text"] for e in first["events"][:2]] == ["message 119", "message 118"]
    second = get_json(f"{server.url}/api/events?limit=50&before={first['before']}")
    third = get_json(f"{server.url}/api/events?limit=50&before={second['before']}")
    assert second["events"][0]["text"] == "message 69"
    assert len(third["events"]) == 20 and third["before"] is None
    status, _, page = get(server.url + "/log")
    assert status == 200 and b"message 119" in page and b"message 69" not in page
    assert b'rel="next"' in page
    assert get(server.url + "/api/events?limit=0")[0] == 400
    assert get(server.url + "/log?before=x")[0] == 400


def read_events(resp: http.client.HTTPResponse, kind: str, deadline: float) -> dict[str, Any]:
    event = ""
    while time.monotonic() < deadline:
        line = resp.readline().decode().rstrip("\n")
        if line.startswith("event: "):
            event = line[7:]
        elif line.startswith("data: ") and event == kind:
            return json.loads(line[6:])  # type: ignore[no-any-return]
    raise AssertionError(f"no {kind} event")


def test_live_stream_sends_new_rows_once(server: Running, store: Path) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    conn.request("GET", "/api/loggers/1001/stream?after=2026-03-01T23:50:00")
    resp = conn.getresponse()
    assert resp.status == 200 and resp.getheader("content-type", "").startswith("text/event-stream")
    deadline = time.monotonic() + 10
    read_events(resp, "ready", deadline)
    insert(store, [("1001", 1, "2026-03-01T23:59:00", 0, 1, 42.0, None, "Temp", "°C")])
    got = read_events(resp, "readings", deadline)
    assert got["rows"] == [[1772409540, 1, 42.0]] and got["last"] == "2026-03-01T23:59:00"
    # a row of another channel in the same second, stored later, still comes, once
    insert(
        store,
        [
            ("1001", 2, "2026-03-01T23:59:00", 0, 1, 7.0, None, "Level", "cm"),
            ("1001", 1, "2026-03-01T23:59:00", 0, 1, 42.0, None, "Temp", "°C"),
        ],
    )
    got = read_events(resp, "readings", deadline)
    assert got["rows"] == [[1772409540, 2, 7.0]]
    conn.close()


def test_missing_store_is_503(tmp_path: Path) -> None:
    running = Running(create_app(tmp_path / "absent.sqlite"))
    try:
        status, _, body = get(running.url + "/api/loggers")
        assert status == 503 and b"does not exist yet" in body
    finally:
        running.stop()


def test_token_required_when_set(store: Path) -> None:
    running = Running(create_app(store), token="s3cret-token")
    try:
        status, headers, body = get(running.url + "/api/loggers")
        assert status == 401 and headers["www-authenticate"] == "Bearer"
        assert b"Authorization: Bearer" in body
        assert get(running.url + "/", {"Authorization": "Bearer wrong-token"})[0] == 401
        auth = {"Authorization": "Bearer s3cret-token"}
        assert get(running.url + "/api/loggers", auth)[0] == 200
        status, headers, _ = get(running.url + "/?token=s3cret-token")
        assert status == 200 and "sondalog_token=s3cret-token" in headers["set-cookie"]
        cookie = {"Cookie": "sondalog_token=s3cret-token"}
        assert get(running.url + "/api/loggers/1001/series", cookie)[0] == 200
    finally:
        running.stop()


def test_listening_beyond_loopback_needs_flag_and_token() -> None:
    check_listen("127.0.0.1", allow_remote=False, token=None)
    check_listen("::1", allow_remote=False, token=None)
    check_listen("localhost", allow_remote=False, token=None)
    with pytest.raises(ConfigError, match=r"<config>: listen: refusing to listen .*loopback"):
        check_listen("0.0.0.0", allow_remote=False, token="s3cret-token")
    with pytest.raises(ConfigError, match="without a token"):
        check_listen("192.0.2.7", allow_remote=True, token=None)
    check_listen("0.0.0.0", allow_remote=True, token="s3cret-token")
    with pytest.raises(ValueError, match="8 or more"):
        create_app(Path("x"), token="short")


def test_cli_refuses_remote_without_token(store: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "sondalog.web",
            "--store",
            str(store),
            "--listen",
            "0.0.0.0:0",
            "--allow-remote",
        ],
        capture_output=True,
        text=True,
        timeout=30,
        env={"PATH": "/usr/bin"},
    )
    assert proc.returncode == 2
    assert "without a token" in proc.stderr


def test_static_files_and_vendored_uplot(server: Running) -> None:
    status, _, body = get(server.url + "/static/vendor/uplot/uPlot.iife.min.js")
    assert status == 200 and b"uPlot" in body
    status, _, body = get(server.url + "/static/vendor/uplot/LICENSE")
    assert status == 200 and b"MIT" in body
    assert get(server.url + "/static/plot.js")[0] == 200
