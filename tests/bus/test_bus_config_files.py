"""Settings files of ``sondalog bus config`` (issue 22): bad files as data cases, each refused
with file, line and field before anything is written; what ``pull`` writes reads back to the
same settings; the host's checks agree with the module core's."""

from __future__ import annotations

import string
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client.bus_config import ModuleState, load_settings, read_settings, render
from sondalog.config import ConfigError, loads
from sondalog.hctmps1 import module as core
from sondalog.hctmps1.eeprom import FACTORY_PASSWORD as CORE_PASSWORD
from sondalog.hctmps1.eeprom import MAX_SUPERVISORS as CORE_MAX
from sondalog.hctmps1.variants import HUM, TEMP
from sondalog.protocol import hctmps1_settings as rules

GOOD = '[[module]]\naddress = "T1"\n'

#: (file text, line, field, words of the message)
MISTAKES = [
    ("", None, "module", "required"),
    ('[module]\naddress = "T1"\n', 1, "module", "array of tables"),
    ('[[module]]\nadress = "T1"\n', 2, "module[0].adress", "did you mean"),
    ("[[module]]\nvariant = 'temp'\n", 1, "module[0].address", "required"),
    ('[[module]]\naddress = "T 1"\n', 2, "module[0].address", "a module ID"),
    ('[[module]]\naddress = "TOOLONG99"\n', 2, "module[0].address", "a module ID"),
    ("[[module]]\naddress = 7\n", 2, "module[0].address", "not an integer"),
    ('[[module]]\naddress = "T1"\nvariant = "pressure"\n', 3, "module[0].variant", "hum, temp"),
    ('[[module]]\naddress = "T1"\nsupervisors = "LOG1"\n', 3, "module[0].supervisors", "array"),
    (
        '[[module]]\naddress = "T1"\nsupervisors = ["LOG1", "L*G"]\n',
        3,
        "module[0].supervisors",
        "'L*G' is not a module ID",
    ),
    (
        '[[module]]\naddress = "T1"\nsupervisors = ["A", "B", "A"]\n',
        3,
        "module[0].supervisors",
        "A is listed twice",
    ),
    (
        '[[module]]\naddress = "T1"\nsupervisors = ['
        + ", ".join(f'"S{n}"' for n in range(9))
        + "]\n",
        3,
        "module[0].supervisors",
        "at most 8",
    ),
    ('[[module]]\naddress = "T1"\nsymbol = "TEMP-1"\n', 3, "module[0].symbol", "ADDP would refuse"),
    ('[[module]]\naddress = "T1"\nsymbol = "TEMPERATURE"\n', 3, "module[0].symbol", "1 to 8"),
    (
        '[[module]]\naddress = "T1"\nautonomous = "yes"\n',
        3,
        "module[0].autonomous",
        "true or false",
    ),
    ('[[module]]\naddress = "T1"\npassword = "a b"\n', 3, "module[0].password", "NEWPW"),
    ('[[module]]\naddress = "T1"\npassword = "x|y"\n', 3, "module[0].password", "NEWPW"),
    ('[[module]]\naddress = "T1"\npassword = "' + "p" * 17 + '"\n', 3, "module[0].password", "16"),
    ('[[module]]\naddress = "T1"\nwas = "T1"\n', 3, "module[0].was", "the address itself"),
    ('[[module]]\naddress = "T1"\ncalibration = 0.5\n', 3, "module[0].calibration", "no command"),
    ('[[module]]\naddress = "T1"\ntemporary = ["PC"]\n', 3, "module[0].temporary", "CSSERVON"),
    (
        GOOD + '\n[[module]]\naddress = "T1"\n',
        5,
        "module[1].address",
        "also the address of module[0]",
    ),
    (
        GOOD + '\n[[module]]\naddress = "T2"\nwas = "T1"\n',
        6,
        "module[1].was",
        "address of module[0]",
    ),
    (
        '[[module]]\naddress = "A"\nwas = "X"\n\n[[module]]\naddress = "B"\nwas = "X"\n',
        3,
        "module[0].was",
        "was of another module",
    ),
    ('[[module]]\naddress = "T1"\n[bus]\nbaud = 9600\n', 3, "bus", "unknown"),
    ('[[module]]\naddress = "T1"\nsymbol = "A"\nsymbol = "B"\n', None, "toml", ""),
]


@pytest.mark.parametrize(("text", "line", "field", "words"), MISTAKES)
def test_a_bad_file_is_refused_with_file_line_and_field(
    tmp_path: Path, text: str, line: int | None, field: str, words: str
) -> None:
    path = tmp_path / "modules.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as caught:
        load_settings(path)
    error = caught.value
    assert error.path == path
    assert error.field == field
    assert error.line == line
    assert words in error.message
    where = f"{path}:{line}: " if line is not None else f"{path}: "
    assert str(error).startswith(where)


def test_a_file_that_is_not_a_regular_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"regular file|not a file|directory"):
        load_settings(tmp_path)


def test_left_out_settings_are_the_factory_values() -> None:
    entry = read_settings(loads(GOOD)).modules[0]
    assert entry.want == ModuleState("T1")
    assert (entry.was, entry.password) == (None, None)
    full = '[[module]]\naddress = "T1"\nsupervisors = []\nsymbol = ""\nautonomous = false\n'
    assert read_settings(loads(full)).modules[0].want == ModuleState("T1")


_ID = st.text(string.ascii_letters + string.digits + "_-", min_size=1, max_size=8)
_SYMBOL = st.text(string.ascii_letters + string.digits + "_", min_size=1, max_size=8)
_STATE = st.builds(
    ModuleState,
    address=_ID,
    variant=st.sampled_from(["temp", "hum", None]),
    supervisors=st.lists(_ID, max_size=8, unique=True).map(tuple),
    symbol=st.none() | _SYMBOL,
    autonomous=st.booleans(),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(_STATE, min_size=1, max_size=4, unique_by=lambda s: s.address), st.booleans())
def test_what_pull_writes_reads_back_to_the_same_settings(
    states: list[ModuleState], full: bool
) -> None:
    text = render(states, full=full)
    assert [m.want for m in read_settings(loads(text)).modules] == states


_PRINTABLE = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=18)


@settings(max_examples=300, deadline=None)
@given(st.one_of(_PRINTABLE, st.text(max_size=10)))
def test_the_host_checks_values_as_the_module_core_does(text: str) -> None:
    assert rules.is_valid_password(text) == core.is_valid_password(text)
    assert rules.is_valid_symbol(text) == core.is_valid_symbol(text)


def test_the_host_knows_the_core_s_limits_and_hello_texts() -> None:
    assert rules.MAX_SUPERVISORS == CORE_MAX
    assert rules.FACTORY_PASSWORD == CORE_PASSWORD
    assert {"temp": TEMP.hello, "hum": HUM.hello} == rules.HELLO_TEXTS
