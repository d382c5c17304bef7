"""The configuration read in few full lines (client/station_read.py, issue 24) against one
``read`` per setting (what ``logger config pull`` and the collector read before): the same
settings, the same values, on virtual loggers of both protocol versions configured randomly
through the protocol; every line within the manual's limits (120 characters a command line,
§3.4.1; 100 an answer line, §3.3)."""

from __future__ import annotations

import asyncio
import contextlib
import re
import string
from decimal import Decimal

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from setting_values import values
from station_helpers import ask, served

from sondalog.ala1 import Version
from sondalog.app.virtual import VirtualLogger
from sondalog.client import station_grammar as g
from sondalog.client.ala1 import Ala1Client
from sondalog.client.ala1_codec import MAX_LINE, ClientError
from sondalog.client.station_grammar import LIMITS
from sondalog.client.station_logger import Session, read_values
from sondalog.client.station_read import (
    MAX_ANSWER,
    Line,
    Part,
    ReadPlan,
    clean,
    exchange,
    read_command,
    read_config,
    read_plan,
)
from sondalog.client.station_schema import BY_PATTERN, SETTINGS, Setting, instances

#: Left out: once set, every line needs iaddress (tested with it below).
_RANDOM = [s for s in SETTINGS if s.pattern != "i address"]
#: Strings with what could confuse a reader: commas (lists join with them), the words that
#: end an answer, boundaries, spaces.
_TEXT = st.one_of(
    st.sampled_from(["OK", "ERROR", "a,b", ",", ",,OK", "x ERROR", "read i name", ""]),
    st.text(string.ascii_letters + string.digits + " ,-_./*#|", max_size=20),
)


def _number(setting: Setting) -> st.SearchStrategy[str]:
    """Numbers up to just below 10^15, with up to 9 decimals: the widest answers."""
    low = Decimal(0) if getattr(setting.grammar, "lo", None) is not None else Decimal("-1e15")
    return st.decimals(low, Decimal("999999999999999.999"), places=3).map(lambda d: format(d, "f"))


def _value(setting: Setting, limits: g.Limits) -> st.SearchStrategy[str]:
    return values(
        setting,
        limits,
        number=_number(setting),
        text=lambda longest: _TEXT.map(lambda t: t[:longest] if longest else t),
    )


@st.composite
def writes(draw: st.DrawFn, version: str) -> list[str]:
    """Writes of valid values typed as a technician would (the logger may refuse some)."""
    limits = LIMITS[version]
    out = []
    for _ in range(draw(st.integers(0, 40))):
        setting = draw(st.sampled_from(_RANDOM))
        n = draw(st.integers(1, setting.count(limits)))
        values = [draw(_value(setting, limits)) for _ in range(2 if setting.dual else 1)]
        try:
            value = ",".join(setting.grammar.check(v, limits) for v in values)
        except ValueError:
            continue
        dual = " all" if setting.dual else ""
        out.append(f"write {setting.name(n)}{dual}{setting.grammar.written(value)}")
    return out


def one_by_one(logger: VirtualLogger, version: str) -> dict[str, str]:
    """Every setting with one ``read`` a line: the reference."""
    values = {}
    for setting, n in instances(LIMITS[version]):
        *data, status, _ = logger.command(read_command(setting, n)).split("\r\n")
        assert status == "OK" and len(data) == 1, (setting.name(n), data)
        values[setting.name(n)] = clean(setting, data[0])
    return values


def check_lines(version: str, prefix: str, raw: bytes) -> None:
    plan = read_plan(version, prefix)
    assert all(len(prefix + line.text) <= MAX_LINE for line in plan.lines)
    answers = raw.decode("latin-1").split("\r\n")
    at = 0
    for line in plan.lines:
        for part, text in zip(line.parts, answers[at:], strict=False):
            if len(part.names) > 1:  # a list: its width is ours to keep within §3.3
                assert len(text) <= MAX_ANSWER, (line.text, text)
        at += len(line.parts) + 1


_SHADOWING = re.compile(r"write command \d+ name\s*/\s*(read|write)", re.IGNORECASE)


@pytest.mark.parametrize("version", ["2.10", "1.16"])
def test_the_fast_read_gives_what_one_read_a_setting_gives(version: str) -> None:
    @settings(max_examples=60, suppress_health_check=list(HealthCheck))
    @given(hand=writes(version))
    def check(hand: list[str]) -> None:
        # A user command named like a protocol command ("read i name") is what the logger
        # runs when that line comes (§6.8): the one-read-a-setting reference cannot read it.
        assume(not any(_SHADOWING.match(command) for command in hand))
        logger = VirtualLogger(version=Version(version))
        for command in hand:
            logger.command(command)
        plan = read_plan(version)
        raw = logger.send("".join(f"{line.text}\r" for line in plan.lines).encode("latin-1"))
        check_lines(version, "", raw)
        fast = plan.values(raw)
        reference = one_by_one(logger, version)
        assert fast == reference
        assert list(fast) == list(reference)  # the order of a station file

    check()


def test_the_widest_values_stay_within_an_answer_line() -> None:
    """Numbers of 15 digits and 9 decimals in every channel: the lists hold fewer channels."""
    logger = VirtualLogger(version=Version.V2_10)
    big = "-999999999999999.999999999"
    for n in range(1, 13):
        for command in (
            f"write channel {n} cal mult format 9.9",
            f"write channel {n} cal mult value {big}",
            f"write channel {n} format 9.9",
            f"write channel {n} record change 999999999999999.999999999",
            f"write channel {n} cal2 mult all {big},{big}",
            f"write channel {n} address all 18446744073709551615,18446744073709551615",
            f"write channel {n} switch advance all 65535,65535",
            f"write channel {n} sampling start 20991231235959",
        ):
            assert logger.command(command) == "OK\r\n", command
    plan = read_plan("2.10")
    raw = logger.send("".join(f"{line.text}\r" for line in plan.lines).encode("latin-1"))
    check_lines("2.10", "", raw)
    assert plan.values(raw) == one_by_one(logger, "2.10")


def test_few_lines_and_bytes() -> None:
    """What the reader is for: 2.10's 841 settings in 80 lines (191 before), 1.16's 283 in
    22 (62 before)."""
    for version, lines, size in (("2.10", 80, 9100), ("1.16", 22, 2400)):
        plan = read_plan(version)
        assert len(plan.names) == len(instances(LIMITS[version]))
        assert len(plan.lines) <= lines
        assert sum(len(line.text) + 1 for line in plan.lines) <= size


def test_over_a_served_logger_with_an_i_address(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Over TCP, in batches, with the ``iaddress`` header every line of a guarded logger
    needs (§8.6.1): the same as one read a setting, for pull's :func:`read_values` and the
    collector's :func:`read_config` (with and without the version it assumed)."""

    async def run() -> None:
        async with served(tmp_path / "a", "2.10") as logger:
            await ask(logger.url, ["write channel 1 name/a,b/", "write i address/k1/"])
            async with await Ala1Client.connect(logger.url) as client:
                session = Session(client, "k1")
                values = await read_values(session, "2.10")
                singles = await client.pipeline(
                    [session.prefix() + read_command(s, n) for s, n in instances(LIMITS["2.10"])]
                )
                for wrong in (None, "1.16", "2.10"):
                    read = await read_config(client, wrong, session.prefix())
                    assert (read.version, read.serial) == ("2.10", "000001")
                    assert read.values() == values
            reference = {
                s.name(n): clean(s, a.lines[0])
                for (s, n), a in zip(instances(LIMITS["2.10"]), singles, strict=True)
            }
            assert values == reference and values["channel 1 name"] == "a,b"

    asyncio.run(run())


def test_a_refused_line_is_seen_without_waiting_for_the_timeout(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """A 1.16 logger refuses what only 2.10 has: the answers end with the refusal and the
    reader says so at once (its client would wait 60 s for lines that never come)."""
    channel = BY_PATTERN["channel {ch} name"]
    lines = [
        Line("read i name", (Part(BY_PATTERN["i name"], ("i name",)),)),
        Line("read channel 12 name 11 name 10 name", tuple(Part(channel, (n,)) for n in "xyz")),
        Line("read channel 1 name 2 name", (Part(channel, ("a",)), Part(channel, ("b",)))),
    ]

    async def run() -> bytes:
        async with (
            served(tmp_path / "a", "1.16") as logger,
            await Ala1Client.connect(logger.url, timeout=60) as client,
        ):
            raw = await asyncio.wait_for(exchange(client, lines), 20)
            # the line is still in step: the next exchange gets its own answers
            read = await asyncio.wait_for(read_config(client, "1.16"), 20)
            assert read.values()["channel 1 name"] == "Supply[V]"
            return raw

    raw = asyncio.run(run())
    assert raw == (
        b"\r\nOK\r\nread channel 12 name 11 name 10 name\r\nERROR\r\n"
        b"Supply[V]\r\nSupply[V]\r\nOK\r\n"
    )
    with pytest.raises(ClientError, match="did not answer"):
        ReadPlan("1.16", "", tuple(lines)).values(raw)


def test_a_peer_that_talks_on_is_left_once_past_what_the_answers_can_be() -> None:
    """Everything an outsider can fill is bounded: a peer sending bytes without end (noise
    on a line, something else on the port) ends the read, it is not waited on for good."""

    async def run() -> None:
        async def talk(_: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            with contextlib.suppress(ConnectionError):
                while True:
                    writer.write(b"x" * 512)
                    await writer.drain()
                    await asyncio.sleep(0.001)

        server = await asyncio.start_server(talk, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        async with server, await Ala1Client.connect(f"tcp://127.0.0.1:{port}", timeout=5) as c:
            with pytest.raises(ClientError, match="more than the answers can be"):
                await asyncio.wait_for(exchange(c, read_plan("2.10").lines), 30)

    asyncio.run(run())
