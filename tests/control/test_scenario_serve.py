"""``sondalog serve`` running a site file's ``[[scenario]]`` (issue 23), observed from outside:
the example site's night ("the level sensor fails at 03:00 and comes back at 05:00, the
logger loses power at 06:00") shows in the logger's record, read over its TCP line."""

from __future__ import annotations

import json
import select
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

from sondalog.client import Client

ROOT = Path(__file__).resolve().parents[2]
SETUP = (
    "write file record size 65536 write channel max number 1",
    "write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0",
    "write channel 1 format 0.2 write channel 1 sampling period 0010",
)


def _site(tmp_path: Path) -> Path:
    text = (ROOT / "examples" / "scenario-site.toml").read_text()
    path = tmp_path / "site.toml"
    path.write_text(text.replace('listen = "127.0.0.1:10001"', 'listen = "127.0.0.1:0"'))
    return path


def _serve(tmp_path: Path, site: Path, *args: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "sondalog", "serve", str(site), "--state", str(tmp_path / "s"),
         *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )  # fmt: skip


def _line(proc: subprocess.Popen[bytes]) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 30)
    assert ready, "serve printed nothing"
    return proc.stdout.readline().decode().strip()


def _post(url: str, body: object) -> object:
    request = urllib.request.Request(url, json.dumps(body).encode(), method="POST")
    with urllib.request.urlopen(request, timeout=30) as response:
        return json.loads(response.read())


def _night(tmp_path: Path, *args: str, hours: int = 8) -> tuple[dict[str, str], list[str]]:
    """Serve the site paused, record channel 1 every 10 minutes, step ``hours``: the record
    (module time HHMM -> the value field) and what serve printed."""
    proc = _serve(tmp_path, _site(tmp_path), "--control", "127.0.0.1:0", *args)
    try:
        logger, control = _line(proc), _line(proc)
        url = "tcp://" + logger.rsplit(" ", 1)[1]
        api = control.rsplit(" ", 1)[1]
        _post(api + "/time/pause", {})
        with Client(url, timeout=10) as client:
            for line in SETUP:
                client.command(line).raise_for_error()
            _post(api + "/time/step", {"seconds": hours * 3600})
            rows = client.command("read record 100 from start").lines
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    said = out.decode().splitlines()
    return {row[8:12]: row.split(",")[2] for row in rows}, said


def test_the_example_sites_night_shows_in_the_record(tmp_path: Path) -> None:
    record, said = _night(tmp_path)
    assert record["0250"] and record["0300"]  # the samples of 03:00 come before the fault
    assert all(record[f"0{h}{m}0"] == "" for h in (3, 4) for m in range(6) if (h, m) != (3, 0))
    assert record["0500"] == "" and record["0510"] != ""  # back after 05:00
    assert record["0600"] != ""  # the samples of 06:00, then the power goes
    assert "0610" not in record and "0620" not in record  # no power, no samples
    assert record["0640"] != "" and record["0800"] != ""  # 30 minutes later it is back
    assert [line.split(": ", 1)[1] for line in said if line.startswith("scenario site")] == [
        "fault disconnected on logger analog:16",
        "clear on logger analog:16",
        "fault power_loss on logger",
    ]


def test_serve_scenario_runs_another_files_entries_instead(tmp_path: Path) -> None:
    other = tmp_path / "other.toml"
    other.write_text('[[scenario]]\nafter = "1h"\naction = "set"\ninput = "analog:16"\n'
                     'value = 0.25\n')  # fmt: skip
    record, said = _night(tmp_path, "--scenario", str(other), hours=2)
    values = [record[k] for k in sorted(record)]
    assert "" not in values  # the site's own 03:00 fault is not run (nor reached)
    assert record["0200"] == "0.25" and record["0050"] != "0.25"
    assert any(line.endswith("set on logger analog:16 = 0.25") for line in said)


def test_a_bad_scenario_stops_serve_with_file_line_and_field(tmp_path: Path) -> None:
    site = _site(tmp_path)
    site.write_text(site.read_text().replace('input = "analog:16"', 'input = "analog:17"', 1))
    proc = _serve(tmp_path, site)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 2
    assert f"{site}:" in err.decode() and "scenario[0].input" in err.decode()
    other = tmp_path / "other.toml"
    other.write_text('[[scenario]]\nat = "26:00"\naction = "restart"\n')
    proc = _serve(tmp_path, _site(tmp_path), "--scenario", str(other), "--check")
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 2 and f"{other}:2: scenario[0].at" in err.decode()
