"""``sondalog logger config pull|plan|apply`` as a user runs them, against a served logger:
exit codes, the diff, errors with file, line and field, a URL that is not a logger."""

from __future__ import annotations

import contextlib
import select
import signal
import socket
import stat
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

CLI = [sys.executable, "-m", "sondalog", "logger", "config"]


@contextlib.contextmanager
def serve(tmp: Path, *extra: str) -> Iterator[str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "sondalog", "logger", "serve", "--listen", "127.0.0.1:0",
         "--state", str(tmp / "state"), *extra],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 15)
    line = proc.stdout.readline().decode() if ready else ""
    try:
        assert line.startswith("listening on "), line
        yield "tcp://" + line.removeprefix("listening on ").strip()
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(10)
        proc.stdout.close()


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, *args], capture_output=True, text=True, timeout=120, cwd=cwd, check=False
    )


@pytest.fixture
def logger(tmp_path: Path) -> Iterator[str]:
    with serve(tmp_path) as url:
        yield url


def test_pull_plan_apply_plan(tmp_path: Path, logger: str) -> None:
    done = run("pull", logger, "-o", "station.toml", cwd=tmp_path)
    assert done.returncode == 0 and done.stdout == "wrote station.toml\n", done.stderr
    assert stat.S_IMODE((tmp_path / "station.toml").stat().st_mode) == 0o600
    assert run("plan", logger, "station.toml", cwd=tmp_path).returncode == 0
    (tmp_path / "s.toml").write_text('[channel.3]\nsampling_period = "000100"\n')
    plan = run("plan", logger, "s.toml", cwd=tmp_path)
    assert plan.returncode == 1
    assert plan.stdout == (
        "logger 000001 (2.10) would change:\n  channel 3 sampling period: 000000 -> 000100\n"
    )
    applied = run("apply", logger, "s.toml", "--yes", cwd=tmp_path)
    assert applied.returncode == 0, applied.stderr
    assert applied.stdout.endswith("logger 000001: 1 write applied and verified\n")
    again = run("plan", logger, "s.toml", cwd=tmp_path)
    assert (again.returncode, again.stdout) == (0, "logger 000001: nothing to change\n")
    full = run("pull", logger, "-o", "all.toml", "--all", cwd=tmp_path)
    assert full.returncode == 0
    text = (tmp_path / "all.toml").read_text()
    assert 'sampling_period = "000100"  # §6.5.14.1' in text
    assert "[message.40]" in text and 'name = "Supply[V]"  # §6.5.3' in text


def test_errors_exit_2_with_file_line_and_field(tmp_path: Path, logger: str) -> None:
    (tmp_path / "bad.toml").write_text('[channel.3]\nsampling_period = "000100"\nformat = "1"\n')
    done = run("plan", logger, "bad.toml", cwd=tmp_path)
    assert done.returncode == 2
    assert "bad.toml:3: channel.3.format: a number format w.p" in done.stderr
    (tmp_path / "s.toml").write_text('[identity]\nnam = "x"\n')
    done = run("apply", logger, "s.toml", "--yes", cwd=tmp_path)
    assert done.returncode == 2 and "did you mean name?" in done.stderr
    done = run("plan", "http://example.net", "bad.toml", cwd=tmp_path)
    assert done.returncode == 2


def test_a_url_that_is_not_a_logger(tmp_path: Path) -> None:
    server = socket.create_server(("127.0.0.1", 0))

    def answer() -> None:
        with contextlib.suppress(OSError):
            conn, _ = server.accept()
            conn.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
            conn.recv(100)
            conn.close()

    threading.Thread(target=answer, daemon=True).start()
    (tmp_path / "s.toml").write_text("")
    port = server.getsockname()[1]
    done = run("plan", f"tcp://127.0.0.1:{port}", "s.toml", cwd=tmp_path)
    server.close()
    assert done.returncode == 2
    assert "no ALA1 answer" in done.stderr or "not an ALA1 logger" in done.stderr


def test_a_refusal_in_the_middle_exits_2_and_lists_what_was_not_applied(
    tmp_path: Path, logger: str
) -> None:
    subprocess.run(
        [sys.executable, "-c", "from sondalog.client import Client\n"
         f"with Client('{logger}') as c: c.command('write channel value')"],
        check=True, timeout=30,
    )  # fmt: skip
    (tmp_path / "s.toml").write_text(
        '[device.2]\ntype = "DS18B20"\n[record]\ntype = "LINEAR"\n[channel.2]\nname = "Voda"\n'
    )
    done = run("apply", logger, "s.toml", "--yes", cwd=tmp_path)
    assert done.returncode == 2
    assert "  applied: device 2 type: MSP430ADC -> DS18B20" in done.stdout
    assert "error: record type: the logger refused 'write record type linear'" in done.stderr
    assert "record type only while the record is empty" in done.stderr
    assert "  not applied: channel 2 name: Supply[V] -> Voda" in done.stderr


def test_a_fleet_file_from_the_command_line(tmp_path: Path, logger: str) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        dead = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    (tmp_path / "fleet.toml").write_text(
        f'[identity]\nname = "Brod"\n[[logger]]\nurl = "{logger}"\n[[logger]]\nurl = "{dead}"\n'
    )
    done = run("apply", "fleet.toml", "--yes", "--parallel", "2", cwd=tmp_path)
    assert done.returncode == 2
    lines = done.stdout.splitlines()[:2]
    assert f"{logger}: changed (1 write verified)" in lines
    assert any(line.startswith(f"{dead}: failed (cannot reach") for line in lines)
    assert done.stdout.splitlines()[2] == "2 loggers: 1 changed, 1 failed"
    plan = run("plan", logger, "fleet.toml", cwd=tmp_path)  # one logger of the file
    assert (plan.returncode, plan.stdout) == (0, "logger 000001: nothing to change\n")
