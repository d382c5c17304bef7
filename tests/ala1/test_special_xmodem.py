"""``read|write special ... xmodem`` in the core (§6.16, §10.4), with the pure XMODEM peer as
the host on a stepped clock. Interoperability with lrzsz over TCP is in tests/integration."""

from __future__ import annotations

from ala1_module import Module

from sondalog.backends.sim.logger import Analog, SimHardware
from sondalog.backends.sim.signals import constant
from sondalog.protocol.tables import build_files
from sondalog.protocol.xmodem import XmodemReceiver, XmodemSender

TABLE1 = b"100.8 550.9\n351.65 1000\n893 1790.53\n"
TABLE2 = b"3\n100.8 550.9\n351.65 1000\n893 1790.53\n4\n100.7 560\n351 1008\n890 1800.2\n"


def pump(m: Module, peer: XmodemSender | XmodemReceiver, command: str, limit: int = 5000) -> bytes:
    """Send ``command``, run the transfer with ``peer`` as the host; returns the final answer."""
    to_module = peer.start(m.now)
    from_module = m.feed(command.encode() + b"\r")
    # nothing but the transfer itself: a receiving module opens with C, a sending one waits
    assert from_module == (b"C" if isinstance(peer, XmodemSender) else b"")
    for _ in range(limit):
        if to_module:
            from_module += m.feed(to_module)
            to_module = b""
        if peer.done:
            break
        if from_module:
            to_module = peer.receive(from_module, m.now)
            if peer.done and isinstance(peer, XmodemSender):
                # the module's answer follows its last ACK (or CAN) in the same chunk
                from_module = from_module[max(from_module.rfind(b"\x06"),
                                              from_module.rfind(b"\x18")) + 1 :]  # fmt: skip
            else:
                from_module = b""
            continue
        deadlines = [d for d in (peer.next_deadline(), m.engine.next_deadline()) if d is not None]
        m.now = max(m.now, min(deadlines))
        to_module = peer.advance(m.now)
        from_module += b"".join(o.data for o in m.engine.advance(m.now))
    else:
        raise AssertionError("transfer did not finish")
    return from_module + m.advance(0.01)


def partitioned() -> Module:
    m = Module(hardware=SimHardware(analog=[Analog(16, constant(0.5)), Analog(17, constant(0.8))]))
    m.ok("write file record size 983040 write file list size 256 write file data size 51200")
    return m


def upload_tables(m: Module, tables: dict[str, bytes]) -> tuple[bytes, bytes]:
    listing, data = build_files(tables)
    assert pump(m, XmodemSender(listing), "write special file list xmodem") == b"OK\r\n"
    assert pump(m, XmodemSender(data, one_k=True), "write special file data xmodem") == b"OK\r\n"
    return listing, data


def test_upload_tables_then_channels_use_them_at_once() -> None:
    m = partitioned()
    m.ok("write channel 1 type 3 write channel 1 address 16 write channel 1 switch output 0")
    m.ok("write channel 1 cal2 mult 1000 write channel 1 format 0.2")
    m.ok("write channel 1 convert file name/tabulka1/")
    assert m.ask("read channel 1 value") == b"\r\nOK\r\n"  # no table yet: no value
    upload_tables(m, {"tabulka1": TABLE1, "tabulka2": TABLE2})
    files = m.engine.state.store.load_files()
    assert files["list"] == b"tabulka1 36\ntabulka2 70\n"  # padding removed
    assert files["data"] == TABLE1 + TABLE2  # cut to the lengths in the list
    x = round(0.5 / 2.5 * 4095) / 4095 * 2500  # 500 mV through the 12-bit A/D, in mV
    expected = 1000 + (1790.53 - 1000) * (x - 351.65) / (893 - 351.65)  # rows 2 and 3
    assert m.read("read channel 1 value") == f"{expected:.2f}"


def test_download_areas_and_the_record() -> None:
    m = partitioned()
    listing, data = upload_tables(m, {"tabulka1": TABLE1})
    got = XmodemReceiver()
    assert pump(m, got, "read special file list xmodem") == b"OK\r\n"
    assert got.data.rstrip(b"\x1a") == listing
    got = XmodemReceiver(crc=False)  # a checksum-only host
    assert pump(m, got, "read special file data xmodem") == b"OK\r\n"
    assert got.data.rstrip(b"\x1a") == data
    m.ok("write text/first/ write text/second/")
    got = XmodemReceiver()
    assert pump(m, got, "read special file record xmodem") == b"OK\r\n"
    assert got.data.rstrip(b"\x1a") == (
        b"20000101000000.0,3,first\r\n20000101000000.1,3,second\r\n"
    )


def test_too_large_an_upload_fails_and_changes_nothing() -> None:
    m = partitioned()
    listing, _ = upload_tables(m, {"tabulka1": TABLE1})
    big = b"x" * 300  # the list area is 256 bytes
    answer = pump(m, XmodemSender(big), "write special file list xmodem")
    assert answer == b"write special file list xmodem\r\nERROR\r\n"
    assert m.engine.state.store.load_files()["list"] == listing


def test_a_cancelled_upload_leaves_the_previous_tables() -> None:
    m = partitioned()
    listing, data = upload_tables(m, {"tabulka1": TABLE1})
    sender = XmodemSender(b"y" * 5000, one_k=True)
    to_module = sender.start(m.now)
    answer = m.feed(b"write special file data xmodem\r")
    to_module = sender.receive(answer, m.now)
    for _ in range(3):  # a couple of blocks, then the host gives up
        answer = m.feed(to_module) if to_module else answer
        to_module = sender.receive(answer, m.now)
    answer = m.feed(sender.cancel()) + m.advance(1)
    assert answer.endswith(b"write special file data xmodem\r\nERROR\r\n")
    assert m.engine.state.store.load_files() == {"list": listing, "data": data}
    assert m.ask("read i version") == b"2.10\r\nOK\r\n"  # the line is back to commands


def test_program_upgrade_resets_and_changes_i_program() -> None:
    m = partitioned()
    m.ok("write com speed 19200")
    m.ok("write i name/site 4/ write channel max number 3")
    m.ok("write text/row/")
    image = b"sondalog-upgrade 1\nprogram: sondalog 9.9.9\n"
    assert pump(m, XmodemSender(image), "write special program xmodem") == b"OK\r\n"
    assert m.read("read i program") == "sondalog 9.9.9"
    assert m.read("read com speed") == "19200"  # kept (§6.16.4)
    assert m.read("read i name") == ""
    assert m.read("read channel max number") == "1"
    assert m.read("read record status") == "0,0.00,CLEAR"
    m.ok("write global reset")
    assert m.read("read i program") == "sondalog 9.9.9"  # a reset does not change the program


def test_an_image_that_is_not_an_upgrade_is_refused() -> None:
    m = partitioned()
    m.ok("write i name/keep/")
    answer = pump(m, XmodemSender(b"\x7fELF binary"), "write special program xmodem")
    assert answer == b"write special program xmodem\r\nERROR\r\n"
    assert m.read("read i name") == "keep"
    assert m.read("read i program").startswith("sondalog ")


def test_writing_the_record_area_replaces_the_rows() -> None:
    m = partitioned()
    m.ok("write text/old/")
    image = b"20070301090000.0,1,1.0,2.0\r\n20070301100000.0,3,note\r\n"
    assert pump(m, XmodemSender(image), "write special file record xmodem") == b"OK\r\n"
    assert m.ask("read record 9 from start") == image + b"OK\r\n"
    bad = pump(m, XmodemSender(b"not a row\r\n"), "write special file record xmodem")
    assert bad.endswith(b"ERROR\r\n")
    assert m.ask("read record 9 from start") == image + b"OK\r\n"


def test_a_transfer_command_stands_alone() -> None:
    m = partitioned()
    m.error("read i version read special file list xmodem")
    m.error("read special file program xmodem")


def test_the_first_xmodem_byte_may_arrive_with_the_command() -> None:
    m = partitioned()
    upload_tables(m, {"tabulka1": TABLE1})
    receiver = XmodemReceiver()
    first = m.feed(b"read special file list xmodem\r" + receiver.start(m.now))
    assert first.startswith(b"\x01\x01\xfe")  # the first block answers the C at once
