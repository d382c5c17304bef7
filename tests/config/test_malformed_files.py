"""Issue 25 item 1, searched: a mistake anywhere in any configuration file gets a
:class:`ConfigError` naming the file (and a field), never a traceback of another kind.

Each example of ``examples/`` is changed in one place at random -- a value replaced by a
value of another type, a key misspelt, a line dropped, a table header doubled -- and loaded
by its format's reader (site file, collector file, board file).
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sondalog.app.site import load_site
from sondalog.backends.linux.board import load_board
from sondalog.collect.config import load_config
from sondalog.config import ConfigError

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

LOADERS: dict[str, Callable[[Path], object]] = {
    "site.toml": load_site,
    "logger-site.toml": load_site,
    "bus-site.toml": load_site,
    "gsm-site.toml": load_site,
    "site-raspberrypi.toml": load_site,
    "collector.toml": load_config,
    "board-raspberrypi.toml": load_board,
}

#: Values of every TOML type, some of them plausible for a wrong key.
VALUES = [
    "true",
    "0",
    "-1",
    "65536",
    "1.5",
    "1e300",
    '""',
    '"x"',
    '"127.0.0.1:99999"',
    '"/dev/zero"',
    "[]",
    "[1, 2]",
    '["a", 3]',
    "{}",
    '{ model = "sine" }',
    "2020-01-01T00:00:00Z",
]
_ASSIGN = re.compile(r"^(\s*)([A-Za-z0-9_\"\-.@]+)(\s*=\s*)(.*)$")


def _mutate(text: str, data: st.DataObject) -> str:
    lines = text.splitlines()
    assigns = [i for i, line in enumerate(lines) if _ASSIGN.match(line)]
    headers = [i for i, line in enumerate(lines) if line.lstrip().startswith("[")]
    how = data.draw(st.sampled_from(["value", "key", "drop", "header"]))
    if how == "value" and assigns:
        i = data.draw(st.sampled_from(assigns))
        m = _ASSIGN.match(lines[i])
        assert m is not None
        lines[i] = m.group(1) + m.group(2) + m.group(3) + data.draw(st.sampled_from(VALUES))
    elif how == "key" and assigns:
        i = data.draw(st.sampled_from(assigns))
        m = _ASSIGN.match(lines[i])
        assert m is not None
        key = m.group(2)
        cut = data.draw(st.integers(0, max(0, len(key) - 1)))
        lines[i] = m.group(1) + key[:cut] + "x" + key[cut + 1 :] + m.group(3) + m.group(4)
    elif how == "drop" and lines:
        del lines[data.draw(st.integers(0, len(lines) - 1))]
    elif headers:
        i = data.draw(st.sampled_from(headers))
        lines.append(lines[i])
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name", sorted(LOADERS))
@settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(data=st.data())
def test_one_mistake_gets_a_config_error(name: str, tmp_path: Path, data: st.DataObject) -> None:
    folder = tmp_path / "f"
    if folder.exists():
        shutil.rmtree(folder)
    shutil.copytree(EXAMPLES, folder)  # files the example names (a board, a CSV) beside it
    path = folder / name
    path.write_text(_mutate((EXAMPLES / name).read_text(), data))
    try:
        LOADERS[name](path)
    except ConfigError as exc:
        assert str(exc).startswith(str(path.parent)), str(exc)  # names the file
        assert exc.field or exc.message
