"""Every row of the command table (hctmps1.md §4), inside and outside <connect>, byte-exact."""

from __future__ import annotations

import pytest
from hctmps1_helpers import Bench, crc_bitwise, frame

from sondalog.hctmps1 import COMMAND_NAMES, CONNECT_COMMANDS, HUM


def test_literal_frames_match_the_spec_framing() -> None:
    # The CRC is the 16-bit value in four hex digits; check value of "123456789" is 4B37.
    assert crc_bitwise(b"123456789") == 0x4B37
    assert frame("T1", "PC", "HELLO") == b":T1,PC,HELLO|9BBE\r\n"
    assert Bench().ask("HELLO") == b":PC,T1,RHELLO.HCTMPS1-temp server (DS18B20)|3409\r\n"


VER = "RGETVER.HVER*1_00*V-2013.SVER*1_1*VI-2018"

# (request body, expected reply body outside <connect>, expected reply body inside <connect>)
# on a fresh temperature module T1 measuring 21.4375 °C. None: no reply.
ROWS: list[tuple[str, str | None, str | None]] = [
    ("REPLY", "RREPLY.NODATA", "RREPLY.NODATA"),
    ("DISCONNECT", "RDISCONNECT.<OK>", "RDISCONNECT.<OK>"),
    ("HELLO", "RHELLO.HCTMPS1-temp server (DS18B20)", "RHELLO.HCTMPS1-temp server (DS18B20)"),
    (
        "GETVER",
        "RGETVER.HVER*1_00*V-2013.SVER*1_1*VI-2018",
        "RGETVER.HVER*1_00*V-2013.SVER*1_1*VI-2018",
    ),
    ("REINIT", None, "RREINIT.<OK>"),
    ("RESEE", None, "RRESEE.<OK>"),
    ("SAVEEE", None, "RSAVEEE.<OK>"),
    ("SETMID.T9", None, "RSETMID.<OK>"),
    ("SETMID.bad id", None, "RSETMID.<FA>"),
    ("SETMID", None, "RSETMID.<FA>"),
    ("ADDSUP.L1", None, "RADDSUP.<OK>"),
    ("ADDSUP.*", None, "RADDSUP.<FA>"),
    ("ADDSUP.TOOLONGID", None, "RADDSUP.<FA>"),
    ("DELSUP.L1", None, "RDELSUP.<FA>"),
    ("LISTSUP", None, "RLISTSUP.<EMPTY>"),
    ("ADDP.TEMP1", None, "RADDP.<OK>"),
    ("ADDP.T-1", None, "RADDP.<FA>"),
    ("DELP.TEMP1", None, "RDELP.<FA>"),
    ("LISTP", None, "RLISTP.<EMPTY>"),
    ("NEWPW.s3cret", None, "RNEWPW.<OK>"),
    ("NEWPW.a b", None, "RNEWPW.<FA>"),
    ("NEWPW.a,b", None, "RNEWPW.<FA>"),
    ("NEWPW.12345678901234567", None, "RNEWPW.<FA>"),
    ("PV", "RPV.21.44", "RPV.21.44"),
    ("CSSERVON.L2", "RCSSERVON.<OK>", "RCSSERVON.<OK>"),
    ("CSSERVON.bad*", "RCSSERVON.<FA>", "RCSSERVON.<FA>"),
    ("CSSERVOFF.L2", "RCSSERVOFF.<FA>", "RCSSERVOFF.<FA>"),
    ("CSSERVLIST", "RCSSERVLIST.<EMPTY>", "RCSSERVLIST.<EMPTY>"),
    ("AUTOON", "RAUTOON.<OK>", "RAUTOON.<OK>"),
    ("AUTOOFF", "RAUTOOFF.<OK>", "RAUTOOFF.<OK>"),
    ("GETMODE", "RGETMODE.MDISOF", "RGETMODE.MDISOF"),
]


def test_the_rows_cover_every_command() -> None:
    covered = {body.split(".")[0] for body, _, _ in ROWS} | {"CONNECT"}
    assert covered == set(COMMAND_NAMES)


@pytest.mark.parametrize(("body", "outside", "inside"), ROWS, ids=[r[0] for r in ROWS])
def test_row_outside_connect(body: str, outside: str | None, inside: str | None) -> None:
    bench = Bench()
    expected = frame("PC", "T1", outside) if outside else b""
    assert bench.ask(body) == expected


@pytest.mark.parametrize(("body", "outside", "inside"), ROWS, ids=[r[0] for r in ROWS])
def test_row_inside_connect(body: str, outside: str | None, inside: str | None) -> None:
    bench = Bench()
    bench.connect()
    expected = frame("PC", "T1", inside) if inside else b""
    assert bench.ask(body) == expected


def test_connect_commands_are_silent_outside_connect() -> None:
    for command in sorted(CONNECT_COMMANDS):
        assert Bench().ask(f"{command}.X1") == b""
        assert Bench().ask(command) == b""


def test_connect_right_and_wrong_password() -> None:
    bench = Bench()
    assert bench.ask("CONNECT.1234") == b""
    assert bench.ask("CONNECT") == b""
    assert bench.ask("CONNECT.0000") == frame("PC", "T1", "RCONNECT.<OK>")
    assert bench.ask("CONNECT.0000") == frame("PC", "T1", "RCONNECT.<OK>")


def test_hello_humidity_variant() -> None:
    bench = Bench(HUM, "H1", 48.5)
    assert bench.ask("HELLO") == frame("PC", "H1", "RHELLO.HCTMPS1-hum server (SHT11)")
    assert bench.ask("PV") == frame("PC", "H1", "RPV.48.5")


def test_lists_with_entries() -> None:
    bench = Bench()
    bench.connect()
    assert bench.ask("ADDSUP.L1") == frame("PC", "T1", "RADDSUP.<OK>")
    assert bench.ask("ADDSUP.L_2") == frame("PC", "T1", "RADDSUP.<OK>")
    assert bench.ask("ADDSUP.L1") == frame("PC", "T1", "RADDSUP.<OK>")  # no duplicate
    assert bench.ask("LISTSUP") == frame("PC", "T1", "RLISTSUP.L1,L_2")
    assert bench.ask("DELSUP.L1") == frame("PC", "T1", "RDELSUP.<OK>")
    assert bench.ask("DELSUP.L1") == frame("PC", "T1", "RDELSUP.<FA>")
    assert bench.ask("LISTSUP") == frame("PC", "T1", "RLISTSUP.L_2")
    assert bench.ask("ADDP.TEMP1") == frame("PC", "T1", "RADDP.<OK>")
    assert bench.ask("LISTP") == frame("PC", "T1", "RLISTP.TEMP1")
    assert bench.ask("ADDP.TEMP2") == frame("PC", "T1", "RADDP.<OK>")  # replaces
    assert bench.ask("DELP.TEMP1") == frame("PC", "T1", "RDELP.<FA>")
    assert bench.ask("DELP.TEMP2") == frame("PC", "T1", "RDELP.<OK>")
    assert bench.ask("LISTP") == frame("PC", "T1", "RLISTP.<EMPTY>")
    assert bench.ask("CSSERVON.A") == frame("PC", "T1", "RCSSERVON.<OK>")
    assert bench.ask("CSSERVON.B") == frame("PC", "T1", "RCSSERVON.<OK>")
    assert bench.ask("CSSERVLIST") == frame("PC", "T1", "RCSSERVLIST.A,B")
    assert bench.ask("CSSERVOFF.A") == frame("PC", "T1", "RCSSERVOFF.<OK>")
    assert bench.ask("CSSERVLIST") == frame("PC", "T1", "RCSSERVLIST.B")


def test_lists_are_limited_to_eight() -> None:
    bench = Bench()
    bench.connect()
    for i in range(8):
        assert bench.ask(f"ADDSUP.S{i}") == frame("PC", "T1", "RADDSUP.<OK>")
        assert bench.ask(f"CSSERVON.C{i}") == frame("PC", "T1", "RCSSERVON.<OK>")
    assert bench.ask("ADDSUP.S8") == frame("PC", "T1", "RADDSUP.<FA>")
    assert bench.ask("CSSERVON.C8") == frame("PC", "T1", "RCSSERVON.<FA>")


def test_getmode_after_autoon() -> None:
    bench = Bench()
    assert bench.ask("AUTOON") == frame("PC", "T1", "RAUTOON.<OK>")
    assert bench.ask("GETMODE") == frame("PC", "T1", "RGETMODE.MDISON")
    assert bench.ask("AUTOOFF") == frame("PC", "T1", "RAUTOOFF.<OK>")
    assert bench.ask("GETMODE") == frame("PC", "T1", "RGETMODE.MDISOF")


def test_setmid_replies_with_the_old_id_then_answers_to_the_new_one() -> None:
    bench = Bench()
    bench.connect()
    assert bench.ask("SETMID.T9") == frame("PC", "T1", "RSETMID.<OK>")
    assert bench.ask("HELLO", dst="T1") == b""
    assert bench.ask("HELLO", dst="T9") == frame("PC", "T9", "RHELLO.HCTMPS1-temp server (DS18B20)")


@pytest.mark.parametrize("body", ["HELLO.x", "PV.1", "GETVER.2", "DISCONNECT.x", "GETMODE.", "FOO"])
def test_malformed_or_unknown_commands_get_no_reply(body: str) -> None:
    assert Bench().ask(body) == b""


def test_command_names_are_case_sensitive() -> None:
    assert Bench().ask("hello") == b""
