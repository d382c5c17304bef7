"""``sondalog serve SITE.toml`` (issue 10): one command serves everything a site file says."""

from __future__ import annotations

import poplib
import re
import select
import signal
import smtplib
import subprocess
import sys
from email.message import EmailMessage
from pathlib import Path

import pytest

from sondalog.client import BlockingBusMaster, Client

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "site.toml"


def _site(tmp_path: Path) -> Path:
    """The example site on free ports (port 0 everywhere)."""
    text = EXAMPLE.read_text()
    text = re.sub(r'(listen|smtp|pop3) = "127\.0\.0\.1:\d+"', r'\1 = "127.0.0.1:0"', text)
    site = tmp_path / "site.toml"
    site.write_text(text)
    return site


def _serve(*args: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", *args],
        stdout=subprocess.PIPE,
        bufsize=0,  # (select sees each line: a burst of them is not buffered away)
        stderr=subprocess.PIPE,
    )


def _lines(proc: subprocess.Popen[bytes], count: int) -> list[str]:
    assert proc.stdout is not None
    lines = []
    while len(lines) < count:
        ready, _, _ = select.select([proc.stdout], [], [], 20)
        assert ready, "serve printed nothing"
        line = proc.stdout.readline().decode()
        assert line, proc.stderr.read().decode() if proc.stderr else ""
        lines.append(line.strip())
    return lines


def _port(line: str) -> int:
    return int(line.rsplit(":", 1)[1].split(",")[0])


def test_serve_runs_the_logger_the_bus_and_the_mail_hub(tmp_path: Path) -> None:
    proc = _serve(str(_site(tmp_path)), "--state", str(tmp_path / "state"))
    try:
        logger, bus, mail = _lines(proc, 3)
        assert logger.startswith("logger SITE-0001 listening on 127.0.0.1:")
        assert bus.startswith("bus listening on 127.0.0.1:")
        ports = [int(p) for p in re.findall(r":(\d+)", mail)]
        with Client(f"tcp://127.0.0.1:{_port(logger)}") as client:
            assert list(client.command("read i snumber").lines) == ["SITE-0001"]
        with BlockingBusMaster(f"tcp://127.0.0.1:{_port(bus)}") as master:
            assert master.run(lambda m: m.hello("T1")).startswith("HCTMPS1")
        message = EmailMessage()
        message["From"], message["To"], message["Subject"] = "u@x", "logger@example.net", "hi"
        message.set_content("##*#read i version##*#")
        with smtplib.SMTP("127.0.0.1", ports[0], timeout=5) as smtp:
            smtp.send_message(message)
        pop = poplib.POP3("127.0.0.1", ports[1], timeout=5)
        pop.user("logger@example.net")
        pop.pass_("secret")
        assert pop.stat()[0] == 1
        pop.quit()
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0
    assert (tmp_path / "state" / "logger").is_dir() and (tmp_path / "state" / "bus").is_dir()


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (('backend = "sim"', 'backend = "nowhere"'), ":5: logger.backend: no hardware backend"),
        (('kind = "hum"', 'kind = "wet"'), ":31: bus.modules[1].kind"),
        (('protocol = "2.10"', 'protocol = "3.0"'), ":17: logger.serve.protocol"),
        (('listen = "127.0.0.1:0"', 'listne = "127.0.0.1:0"'), ":16: logger.serve.listne"),
    ],
)
def test_a_wrong_site_file_exits_2_naming_file_line_and_field(
    tmp_path: Path, edit: tuple[str, str], expected: str
) -> None:
    site = _site(tmp_path)
    site.write_text(site.read_text().replace(*edit, 1))
    done = subprocess.run(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(tmp_path / "s")],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2, done.stderr
    assert f"{site}{expected}" in done.stderr


def test_serving_beyond_loopback_needs_allow_remote(tmp_path: Path) -> None:
    site = _site(tmp_path)
    site.write_text(site.read_text().replace('listen = "127.0.0.1:0"', 'listen = "0.0.0.0:0"', 1))
    done = subprocess.run(
        [sys.executable, "-m", "sondalog", "serve", str(site)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2 and "--allow-remote" in done.stderr


def test_a_mail_hub_beyond_loopback_needs_allow_remote_too(tmp_path: Path) -> None:
    site = _site(tmp_path)
    text = site.read_text()
    assert 'smtp = "127.0.0.1:0"' in text
    site.write_text(text.replace('smtp = "127.0.0.1:0"', 'smtp = "0.0.0.0:0"', 1))
    done = subprocess.run(
        [sys.executable, "-m", "sondalog", "serve", str(site)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2, done.stderr
    assert "mail.smtp: 0.0.0.0 is reachable from other machines" in done.stderr
    assert "--allow-remote" in done.stderr
