"""``python -m sondalog.web`` (issue 26): a taken address is named, and ``--help`` is plain
text (no reST markup printed literally)."""

from __future__ import annotations

import re
import socket
import subprocess
import sys
from pathlib import Path

WEB = [sys.executable, "-m", "sondalog.web"]


def test_a_taken_address_is_named(store: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [*WEB, "--store", str(store), "--listen", f"127.0.0.1:{port}"],
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert done.returncode == 2
    assert f"cannot listen on 127.0.0.1:{port}: Address already in use" in done.stderr
    assert "Traceback" not in done.stderr and done.stdout == ""


def test_help_is_plain_text() -> None:
    done = subprocess.run([*WEB, "--help"], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0
    assert "The dashboard alone, over an existing store" in done.stdout
    assert re.search(r"`|:(?:class|mod|func):", done.stdout) is None, done.stdout


def test_a_bad_or_remote_listen_is_refused_before_serving(store: Path) -> None:
    for listen, message in [
        ("8080", "--listen: expected HOST:PORT, got '8080'"),
        ("127.0.0.1:70000", "--listen: port must be a number 0..65535"),
        ("0.0.0.0:8080", "python -m sondalog.web: --listen: refusing to listen on 0.0.0.0"),
    ]:
        done = subprocess.run(
            [*WEB, "--store", str(store), "--listen", listen],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert done.returncode == 2, done.stderr
        assert message in done.stderr and "Traceback" not in done.stderr


def test_store_options_for_a_server(store: Path, pg_dsn: str) -> None:
    """``--store`` takes a PostgreSQL connection string (issue 24); a bad one, or ``--file``
    with a file as ``--store``, is a message and exit code 2; a good one is served."""
    for args, message in [
        (["--store", "host=h nonsense", "--listen", "127.0.0.1:0"], "--store: not a valid"),
        (["--store", str(store), "--file", str(store)], "--file: only with a PostgreSQL server"),
    ]:
        done = subprocess.run([*WEB, *args], capture_output=True, text=True, timeout=30)
        assert done.returncode == 2, done.stderr
        assert message in done.stderr and "Traceback" not in done.stderr
    proc = subprocess.Popen(
        [*WEB, "--store", pg_dsn, "--file", str(store), "--listen", "127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        url = re.search(r"http://\S+/", line)
        assert url, line
        import urllib.error
        import urllib.request

        try:  # the server has no readings table yet: 503, naming no DSN
            urllib.request.urlopen(url.group(0) + "api/loggers", timeout=30)
            raise AssertionError("expected 503")
        except urllib.error.HTTPError as exc:
            body = exc.read().decode()
            assert exc.code == 503 and "the [postgres] server" in body, body
            assert "dbname" not in body
    finally:
        proc.terminate()
        proc.wait(10)
