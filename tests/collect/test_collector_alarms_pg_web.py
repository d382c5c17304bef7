"""The dashboard of a collector that keeps its alarms on PostgreSQL (issue 21), for real: a
``sondalog collect`` with ``[postgres] alarms = true`` and its dashboard (with a token)
downloads a served logger whose level crosses the rule's limit; the alarm it raises on the
server is shown by the dashboard (overview, the logger's page, the log's history,
``/api/alarms``), acknowledged through the dashboard's POST (token and same-origin rules),
applied by the collector, and ``sondalog alarms list`` then shows it acknowledged.

Without the feature the dashboard reads the alarm tables of its SQLite store, which has
none: it shows nothing and the POST answers 404."""

from __future__ import annotations

import json
import signal
import sqlite3
import subprocess
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from contextlib import closing
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import psycopg
from served_logger import CLI, serving

from sondalog.collect.alarms import alarm_id

RULE = "level high"
SUBJECT = "000001/2"
TOKEN = "s3cret-token-pg1"
BEARER = {"Authorization": f"Bearer {TOKEN}"}


def _config(folder: Path, url: str, dsn: str) -> Path:
    path = folder / "collector.toml"
    path.write_text(
        f'[sqlite]\npath = "store.sqlite"\n\n[web]\nlisten = "127.0.0.1:0"\ntoken = "{TOKEN}"\n\n'
        f'[postgres]\ndsn = "{dsn}"\nalarms = true\n\n'
        f'[[source]]\nurl = "{url}"\nname = "station"\ninterval = 0.5\ntimeout = 1\n'
        "retry = 0.3\nretry_max = 0.5\n\n"
        f'[[alarm]]\nkind = "threshold"\nname = "{RULE}"\nchannel = "Level"\n'
        "above = 1.8\nclear = 1.2\n"
    )
    return path


def _request(
    url: str, *, method: str = "GET", headers: dict[str, str] | None = None
) -> tuple[int, bytes]:
    req = urllib.request.Request(url, data=b"" if method == "POST" else None, method=method)
    for key, value in (headers or {}).items():
        req.add_header(key, value)
    try:
        with urllib.request.urlopen(req, timeout=10) as resp:
            return resp.status, resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def _page(url: str) -> str:
    status, body = _request(url, headers=BEARER)
    assert status == 200, body
    return body.decode()


def _alarms(web: str) -> dict[str, Any]:
    status, body = _request(web + "/api/alarms", headers=BEARER)
    assert status == 200, body
    return dict(json.loads(body))


def _wait(condition: Callable[[], bool], timeout: float, what: str, log: list[str]) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}; log:\n{''.join(log)}")
        time.sleep(0.2)


def _listed(config: Path) -> str:
    done = subprocess.run(
        [*CLI, "alarms", "list", str(config)], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_the_dashboard_shows_and_acknowledges_alarms_kept_on_postgres(
    tmp_path: Path, pg_dsn: str
) -> None:
    site = tmp_path / "site.toml"
    site.write_text(  # input 16 goes high after 3 s
        "[logger]\n[[logger.analog]]\naddress = 16\n"
        'signal = { model = "steps", schedule = [[0, 1.0], [3, 2.0]] }\n'
    )
    ident = alarm_id(RULE, SUBJECT)
    with serving(tmp_path, "--site", str(site)) as served:
        config = _config(tmp_path, served.url, pg_dsn)
        proc = subprocess.Popen(
            [*CLI, "collect", str(config)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        log: list[str] = []
        listening = threading.Event()

        def drain() -> None:  # the collector's log, read all along (a full pipe would stall it)
            assert proc.stderr is not None
            for raw in proc.stderr:
                log.append(raw.decode(errors="replace"))
                if log[-1].startswith("dashboard on "):
                    listening.set()

        reader = threading.Thread(target=drain, daemon=True)
        reader.start()
        try:
            assert listening.wait(30), "".join(log)
            web = next(line for line in log if line.startswith("dashboard on ")).split()[-1]
            web = web.rstrip("/")
            served.ask(
                "write date " + datetime.now(UTC).strftime("%Y%m%d%H%M%S"),
                "write channel max number 2",
                "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0",
                "write channel 2 name/Level[m]/ write channel 2 format 0.3",
                "write channel 1 record change 0 write channel 2 record change 0",
                "write channel sampling period 000001 000001",
            )
            _wait(lambda: bool(_alarms(web)["active"]), 40, "the alarm on the dashboard", log)

            # shown: /api/alarms, the overview, the logger's page, the log's history
            data = _alarms(web)
            [on] = data["active"]
            assert (on["id"], on["rule"], on["subject"], on["logger"], on["state"]) == (
                ident,
                RULE,
                SUBJECT,
                "000001",
                "raised",
            )
            assert on["value"] > 1.8 and not on["ack_requested"]
            assert [(h["id"], h["what"]) for h in data["history"]] == [(ident, "raised")]
            overview = _page(web + "/")
            assert RULE in overview and f'action="/api/alarms/{ident}/ack"' in overview
            assert "1 active alarm" in overview
            assert RULE in _page(web + "/loggers/000001")
            history = _page(web + "/log")
            assert "Alarm history" in history and on["text"] in history

            # the POST: the token, then the same-origin rule
            ack = f"{web}/api/alarms/{ident}/ack"
            assert _request(ack, method="POST", headers={"Origin": web})[0] == 401
            evil = {**BEARER, "Origin": "http://evil.example"}
            assert _request(ack, method="POST", headers=evil)[0] == 403
            status, body = _request(ack, method="POST", headers={**BEARER, "Origin": web})
            assert status == 202, body
            assert json.loads(body)["ack_requested"] is True

            # the collector applies it on its next turn; the CLI sees it on the server too
            _wait(
                lambda: f"{ident}  acknowledged" in _listed(config),
                20,
                "the acknowledgement in `sondalog alarms list`",
                log,
            )
            [on] = _alarms(web)["active"]
            assert on["state"] == "acknowledged" and on["acked_time"]
            status, body = _request(ack, method="POST", headers={**BEARER, "Origin": web})
            assert status == 409 and json.loads(body)["state"] == "acknowledged"
            whats = [h["what"] for h in _alarms(web)["history"]]
            assert whats == ["acknowledged", "raised"]
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            reader.join(5)
        assert proc.returncode == 0, "".join(log)
    with psycopg.connect(pg_dsn) as db:
        acks = db.execute("SELECT alarm, by, done IS NOT NULL FROM alarm_acks").fetchall()
    assert acks == [(ident, "dashboard", True)]
    with closing(sqlite3.connect(tmp_path / "store.sqlite")) as store:
        tables = {r[0] for r in store.execute("SELECT name FROM sqlite_master")}
    assert "readings" in tables and "alarm_states" not in tables  # all on the server
