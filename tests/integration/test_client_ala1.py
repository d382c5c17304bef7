"""The host client (issue 2 "Host side"): parsed answers, ``check``, ``sum`` and ``crcsum``
verification (§8.3, §8.4), cross-checked against the real ``cksum`` program."""

from __future__ import annotations

import asyncio
import shutil
import subprocess
from collections.abc import Awaitable, Callable

import pytest
from ala1_served import ServedLogger

from sondalog.client import (
    Ala1Client,
    Client,
    CommandFailed,
    ConnectionLost,
    CrcMismatch,
    IncompleteAnswer,
    NoAnswer,
    Request,
    Status,
    SumMismatch,
    TcpEndpoint,
    parse_url,
    with_check,
)
from sondalog.client.endpoints import SerialEndpoint


def test_with_check_matches_the_manual() -> None:
    assert with_check("read date") == "check 890 read date"  # §8.3.1


def test_parse_url() -> None:
    assert parse_url("tcp://127.0.0.1:10001") == TcpEndpoint("127.0.0.1", 10001)
    assert parse_url("TCP://[::1]:5/") == TcpEndpoint("::1", 5)
    assert parse_url("serial:///dev/ttyS0") == SerialEndpoint("/dev/ttyS0", 9600)
    assert parse_url("serial:///tmp/ala1?baud=115200") == SerialEndpoint("/tmp/ala1", 115200)
    assert parse_url("pty:ala1?baud=19200") == SerialEndpoint("ala1", 19200)
    bad_urls = (
        "127.0.0.1:10001",
        "tcp://host",
        "tcp://host:x",
        "tcp://",
        "serial://host/dev/ttyS0",
        "serial:///dev/ttyS0?baud=fast",
        "serial:///dev/ttyS0?parity=E",
        "serial://",
        "udp://host:1",
    )
    for bad in bad_urls:
        with pytest.raises(ValueError):
            parse_url(bad)


def test_answers_are_parsed(shared_logger: ServedLogger) -> None:
    with Client(shared_logger.url, timeout=2) as logger:
        got = logger.command("read i version")
        assert (got.status, got.lines, got.raw) == (Status.OK, ("2.10",), b"2.10\r\nOK\r\n")
        chained = logger.command("read i version read i device read text/x y/")
        assert chained.ok and chained.lines == ("2.10", "ALA1", "x y")
        bad = logger.command("reed date")
        assert bad.error and bad.raw == b"reed date\r\nERROR\r\n"
        with pytest.raises(CommandFailed):
            bad.raise_for_error()
        echoed = logger.command("+read i vx\x08ersion")
        assert echoed.echo == "+read i vx\x08 \x08ersion" and echoed.lines == ("2.10",)
        assert logger.command("+reed").error
        long = logger.command("read text/" + "y" * 150)
        assert long.error
        answers = logger.pipeline(["read i version", Request("read i device", sum=True)])
        assert [a.lines for a in answers] == [("2.10",), ("ALA1",)]


def test_check_sum_and_crcsum_verified_on_a_real_logger(shared_logger: ServedLogger) -> None:
    with Client(shared_logger.url, timeout=2) as logger:
        got = logger.command("read i version read i device", check=True, sum=True, crcsum=True)
        assert got.command.startswith("check ") and got.lines == ("2.10", "ALA1")
        assert got.raw.endswith(b"00154,OK\r\n")
        assert got.raw.startswith(b"00193,2.10\r\n00255,ALA1\r\n")
        assert got.crc is not None and got.crc[1] == len(b"00193,2.10\r\n00255,ALA1\r\n")
        assert logger.command("write channel max number 12", sum=True, crcsum=True).ok
        names = logger.command("read channel name", crcsum=True)
        assert names.lines == (",".join(["Supply[V]"] * 12),)
        # A wrong check gets no answer at all (§8.3.1).
        with pytest.raises(NoAnswer):
            logger.command("check 1 read date", timeout=0.3)
        assert logger.command("read i version").ok


@pytest.mark.skipif(shutil.which("cksum") is None, reason="needs the cksum program")
def test_crcsum_agrees_with_the_cksum_program(shared_logger: ServedLogger) -> None:
    with Client(shared_logger.url, timeout=2) as logger:
        got = logger.command(
            "read date read i version read i device read com speed", sum=True, crcsum=True
        )
    covered = got.raw[: got.raw.rindex(b"\r\n", 0, len(got.raw) - len(b"00154,OK\r\n"))]
    covered = covered[: covered.rindex(b"\r\n") + 2]  # every line before the crcsum line
    printed = subprocess.run(["cksum"], input=covered, capture_output=True, check=True).stdout
    crc, length = printed.split()[:2]
    assert got.crc == (int(crc), int(length))
    crc_line = got.raw.split(b"\r\n")[-3].decode()
    assert crc_line.split(",", 1)[1] == f"{int(crc)},{int(length)}"


# -- a fake logger that answers with canned bytes -------------------------------------------


def run_against(answer: bytes, test: Callable[[Ala1Client], Awaitable[None]]) -> None:
    """Run ``test`` with a client of a fake logger that answers every line with ``answer``."""

    async def main() -> None:
        async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            while await reader.readuntil(b"\r"):
                if answer == b"<close>":
                    writer.close()
                    return
                writer.write(answer)

        server = await asyncio.start_server(handle, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        client = await Ala1Client.connect(f"tcp://127.0.0.1:{port}", timeout=0.3)
        try:
            await test(client)
        finally:
            await client.close()
            server.close()

    asyncio.run(main())


GOOD_SUM = b"00676,20000101000000\r\n00622,768956041,22\r\n00154,OK\r\n"


def _expect(exc: type[Exception], **options: bool) -> Callable[[Ala1Client], Awaitable[None]]:
    async def test(client: Ala1Client) -> None:
        with pytest.raises(exc):
            await client.command("read date", **options)

    return test


def test_good_canned_answers_pass() -> None:
    async def with_sum(client: Ala1Client) -> None:
        got = await client.command("read date", sum=True, crcsum=True)
        assert got.lines == ("20000101000000",) and got.crc == (768956041, 22)

    async def without_sum(client: Ala1Client) -> None:
        got = await client.command("read date", crcsum=True)
        assert got.lines == ("20000101000000",) and got.crc == (1211329680, 16)

    run_against(GOOD_SUM, with_sum)
    run_against(b"20000101000000\r\n1211329680,16\r\nOK\r\n", without_sum)


@pytest.mark.parametrize(
    "answer",
    [
        GOOD_SUM.replace(b"00676,", b"00677,"),  # data line sum
        GOOD_SUM.replace(b"00154,OK", b"00155,OK"),  # OK line sum
        GOOD_SUM.replace(b"20000101000000", b"20000101000001"),  # corrupted data
        b"20000101000000\r\n00154,OK\r\n",  # missing sum prefix
    ],
)
def test_corrupted_sum_raises(answer: bytes) -> None:
    run_against(answer, _expect(SumMismatch, sum=True))


@pytest.mark.parametrize(
    "answer",
    [
        b"20000101000000\r\n1211329681,16\r\nOK\r\n",  # wrong CRC
        b"20000101000000\r\n1211329680,17\r\nOK\r\n",  # wrong length
        b"20000101000001\r\n1211329680,16\r\nOK\r\n",  # data changed in transit
        b"OK\r\n",  # no crcsum line
        b"20000101000000\r\nnot a crc\r\nOK\r\n",
    ],
)
def test_corrupted_crcsum_raises(answer: bytes) -> None:
    run_against(answer, _expect(CrcMismatch, crcsum=True))


def test_no_answer_incomplete_and_closed_are_distinct() -> None:
    run_against(b"", _expect(NoAnswer))
    run_against(b"20000101000000\r\n", _expect(IncompleteAnswer))
    run_against(b"<close>", _expect(ConnectionLost))


def test_quiet_ends_by_silence() -> None:
    async def test(client: Ala1Client) -> None:
        client.quiet_period = 0.1
        got = await client.command("read date", quiet=True)
        assert got.status is Status.SILENT and got.lines == ("20000101000000",)
        assert got.command == "quiet read date"

    run_against(b"20000101000000\r\n", test)
    run_against(b"", _silent)


async def _silent(client: Ala1Client) -> None:
    client.quiet_period = 0.1
    got = await client.command("write date 000000", quiet=True)
    assert got.status is Status.SILENT and got.lines == () and got.raw == b""


def test_command_text_may_not_carry_a_line_end(shared_logger: ServedLogger) -> None:
    with Client(shared_logger.url) as logger, pytest.raises(ValueError):
        logger.command("read date\rwrite date 000000")
