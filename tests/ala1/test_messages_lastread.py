"""``read record N from lastread shift`` as a message's command (§6.8.4.1, gsm.md §5): the
point moves only when the carrier reports that every destination got the message; after a
failure the next message carries the same rows again, and the new ones."""

from __future__ import annotations

from ala1_module import Module
from messages_harness import queued, run_for

from sondalog.ala1.outbox import Outgoing


def configured(m: Module) -> None:
    """The §6.8.4.1 example, sent by e-mail through the modem."""
    assert m.ask("write address 1 type email") == b"OK\r\n"
    assert m.ask("write command 1 value/read record 1000 from lastread shift/") == b"OK\r\n"
    assert m.ask("write message 1 command 1") == b"OK\r\n"
    assert m.ask("write message 1 address 1") == b"OK\r\n"
    m.ok("write address 1 value/user@example.net/ write com device wavecom41")
    m.ok("write date 20070301090000")


def send(m: Module) -> Outgoing:
    m.ok("write message 1 run 1")
    run_for(m, 0)
    (outgoing,) = queued(m)
    return outgoing


def test_the_point_moves_only_after_a_successful_delivery(module: Module) -> None:
    configured(module)
    module.ok("write text/one/")
    outgoing = send(module)
    assert outgoing.body == "20070301090000.0,3,one\r\nOK\r\n"
    assert module.read("read record last read") == ""  # not yet delivered
    module.engine.outbox.done(outgoing.ident, True)
    assert module.read("read record last read") == "20070301090000.0"
    module.ok("write text/two/")
    assert send(module).body == "20070301090000.1,3,two\r\nOK\r\n"


def test_a_failed_delivery_keeps_the_data_for_the_next_message(module: Module) -> None:
    configured(module)
    module.ok("write text/one/")
    failed = send(module)
    module.engine.outbox.done(failed.ident, False)
    assert module.read("read record last read") == ""
    module.ok("write text/two/")
    again = send(module)
    assert again.body == "20070301090000.0,3,one\r\n20070301090000.1,3,two\r\nOK\r\n"
    module.engine.outbox.done(again.ident, True)
    assert module.read("read record last read") == "20070301090000.1"


def test_the_point_survives_a_restart_only_once_delivered(tmp_path: object) -> None:
    from pathlib import Path

    assert isinstance(tmp_path, Path)
    db = tmp_path / "ala1.sqlite"
    first = Module(db=db)
    configured(first)
    first.ok("write text/one/")
    outgoing = send(first)
    first.engine.outbox.done(outgoing.ident, True)
    first.store.close()
    second = Module(db=db)
    assert second.read("read record last read") == "20070301090000.0"
    second.store.close()


def test_a_point_moved_meanwhile_stays_where_it_was_put(module: Module) -> None:
    configured(module)
    module.ok("write text/one/ write text/two/")
    outgoing = send(module)
    module.ok("write record last read/20070301090000.0/")
    module.engine.outbox.done(outgoing.ident, True)
    assert module.read("read record last read") == "20070301090000.0"


def test_an_explicit_write_of_the_point_is_not_deferred(module: Module) -> None:
    configured(module)
    module.ok("write command 1 value|read record 9 from lastread shift write record last read/x/|")
    module.ok("write text/one/")
    outgoing = send(module)
    assert module.read("read record last read") == "x"
    module.engine.outbox.done(outgoing.ident, False)
    assert module.read("read record last read") == "x"


def test_a_shift_on_a_line_moves_at_once(module: Module) -> None:
    configured(module)
    module.ok("write text/one/")
    assert module.ask("read record 9 from last read shift").startswith(b"20070301090000.0,3,")
    assert module.read("read record last read") == "20070301090000.0"


def test_local_delivery_counts_as_successful(module: Module) -> None:
    configured(module)
    module.ok("write com device local write text/one/")
    assert module.ask("write message 1 run 1 write com close").endswith(b",3,one\r\nOK\r\n")
    assert module.read("read record last read") == "20070301090000.0"
