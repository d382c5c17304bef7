"""The collector's ``[web]`` table and the dashboard it serves (``sondalog collect``)."""

from __future__ import annotations

import contextlib
import json
import signal
import socket
import sqlite3
import subprocess
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from served_logger import CLI, serving

from sondalog.collect.config import parse_config
from sondalog.collect.web_config import TOKEN_ENV
from sondalog.config import ConfigError, loads

SOURCE = '[[source]]\nurl = "tcp://127.0.0.1:10001"\n'
TOKEN = "s3cret-token-1"


def config(text: str, env: dict[str, str] | None = None) -> Any:
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(TOKEN_ENV, raising=False)
        for key, value in (env or {}).items():
            mp.setenv(key, value)
        return parse_config(loads(SOURCE + text, Path("c.toml"))).web


def test_web_defaults_to_loopback_8080() -> None:
    web = config("")
    assert (web.enabled, web.host, web.port, web.token, web.explicit) == (
        True,
        "127.0.0.1",
        8080,
        None,
        False,
    )
    web = config('[web]\nlisten = "127.0.0.1:0"\n')
    assert (web.port, web.explicit) == (0, True)
    assert config("[web]\nenabled = false\n").enabled is False


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[web]\nlisten = "0.0.0.0:8080"\n', "c.toml:4: web.listen: refusing to serve"),
        (
            '[web]\nlisten = "192.0.2.1:8080"\nallow_remote = true\n',
            "c.toml:3: web.token: refusing to serve the dashboard on 192.0.2.1 without a token",
        ),
        ('[web]\nlisten = "8080"\n', "c.toml:4: web.listen: expected HOST:PORT, got '8080'"),
        ("[web]\nlisten = 8080\n", 'c.toml:4: web.listen: must be "HOST:PORT", not an integer'),
        ('[web]\nlisten = "127.0.0.1:70000"\n', "c.toml:4: web.listen: port must be a number"),
        ('[web]\ntoken = "short"\n', "c.toml:4: web.token: must be 8 or more characters"),
        ("[web]\nallow_remote = 1\n", "c.toml:4: web.allow_remote: must be true or false"),
        ("[web]\nport = 1\n", "c.toml:4: web.port: unknown table or key 'port' (known: allow"),
        ("[web]\nenabeld = false\n", "c.toml:4: web.enabeld: unknown table or key 'enabeld' (did"),
    ],
)
def test_bad_web_tables_are_refused(text: str, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        config(text)
    assert str(info.value).startswith(message), str(info.value)


def test_a_bad_token_is_not_echoed() -> None:
    with pytest.raises(ConfigError) as info:
        config('[web]\ntoken = "s3cr t-token"\n')
    assert "s3cr t" not in str(info.value)
    with pytest.raises(ConfigError, match=r"web.token: \$SONDALOG_WEB_TOKEN: must be 8 or more"):
        config("", {TOKEN_ENV: "short"})


def test_beyond_loopback_with_allow_remote_and_a_token() -> None:
    text = f'[web]\nlisten = "0.0.0.0:8080"\nallow_remote = true\ntoken = "{TOKEN}"\n'
    web = config(text)
    assert (web.host, web.allow_remote, web.token) == ("0.0.0.0", True, TOKEN)
    from_env = config('[web]\nlisten = "0.0.0.0:8080"\nallow_remote = true\n', {TOKEN_ENV: TOKEN})
    assert from_env.token == TOKEN


def test_check_reports_a_refused_listen_with_exit_2(tmp_path: Path) -> None:
    path = tmp_path / "c.toml"
    path.write_text(SOURCE + '[web]\nlisten = "0.0.0.0:8080"\n')
    done = subprocess.run([*CLI, "collect", str(path), "--check"], capture_output=True, text=True)
    assert done.returncode == 2
    assert f"{path}:4: web.listen: refusing to serve the dashboard on 0.0.0.0" in done.stderr


def test_a_taken_listen_port_is_exit_2(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        path = tmp_path / "c.toml"
        path.write_text(SOURCE + f'[web]\nlisten = "127.0.0.1:{port}"\n')
        done = subprocess.run(
            [*CLI, "collect", str(path)], capture_output=True, text=True, timeout=30
        )
    assert done.returncode == 2
    assert f"the dashboard cannot listen on 127.0.0.1:{port}" in done.stderr


SITE = """[logger]
[[logger.analog]]
address = 16
signal = { model = "sine", mean = 1.2, amplitude = 1.0, period = 600 }
[[logger.pulses]]
timer = true
rate = 3.0
[logger.gsm]
signal = { model = "constant", value = 17 }
credit = { model = "constant", value = 123.5 }
"""


def get_json(url: str) -> Any:
    with urllib.request.urlopen(url, timeout=10) as answer:
        return json.load(answer)


def test_the_collector_serves_what_it_collects(tmp_path: Path) -> None:
    site = tmp_path / "site.toml"
    site.write_text(SITE)
    with serving(tmp_path, "--site", str(site), "--speed", "20") as logger:
        logger.ask(
            "write date 20070301000000",
            "write channel max number 5",
            "write channel 2 type 3 write channel 2 address 16 write channel 2 switch output 0",
            "write device 4 type msp430ta write channel 3 device 4 write channel 3 type 6",
            "write channel 4 type 12 write channel 5 type 11",
            "write channel 2 name/Level[m]/ write channel 3 name/Rain[imp]/",
            "write channel sampling period 000010 000010 000010 000010 000010",
        )
        time.sleep(1)  # a few rows at 20x
        path = tmp_path / "c.toml"
        path.write_text(
            f'[[source]]\nurl = "{logger.url}"\ninterval = 1\n[web]\nlisten = "127.0.0.1:0"\n'
        )
        proc = subprocess.Popen(
            [*CLI, "collect", str(path)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        try:
            assert proc.stderr is not None
            # log lines of the first download may come before the dashboard's address
            for _ in range(50):
                line = proc.stderr.readline().decode()
                if line.startswith("dashboard on ") or not line:
                    break
            assert line.startswith("dashboard on http://127.0.0.1:"), line
            web = line.split()[-1]
            deadline = time.monotonic() + 20
            while (
                not (entries := get_json(web + "api/loggers")["loggers"])
                or not entries[0]["signal"]
                or entries[0]["sources"][0]["state"] != "ok"  # not in the middle of a contact
            ):
                assert time.monotonic() < deadline, entries
                time.sleep(0.2)
            (entry,) = entries
            assert (entry["logger"], entry["signal"], entry["credit"]) == ("000001", 17, 123.5)
            assert entry["record_fill"] and not entry["trouble"]
            assert entry["sources"][0]["state"] == "ok"
            kinds = {c["channel"]: (c["name"], c["unit"], c["kind"]) for c in entry["channels"]}
            assert kinds[2] == ("Level", "m", "line") and kinds[3] == ("Rain", "imp", "bars")
            with contextlib.closing(sqlite3.connect(tmp_path / "collector.sqlite")) as db:
                types = db.execute("SELECT channel, type FROM channels ORDER BY channel").fetchall()
            assert types == [(1, 1), (2, 3), (3, 6), (4, 12), (5, 11)]
            proc.send_signal(signal.SIGINT)
            assert proc.wait(timeout=20) == 0
            with pytest.raises(OSError):
                urllib.request.urlopen(web, timeout=2)
        finally:
            if proc.poll() is None:
                proc.kill()
            proc.wait()
