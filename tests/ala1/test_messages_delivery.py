"""Where a message goes and when it waits (§6.14, §6.14.9; gsm.md §5): the cable line with
``com device local`` (plain text, blocked from a line's first command until ``write com
close`` or a reconnection), the outbox with sms/email destinations for ``wavecom`` (waiting
while the modem is busy), the body as a line would answer (``counter`` across messages)."""

from __future__ import annotations

from ala1_module import Module
from messages_harness import queued, released, run_for

from sondalog.ala1.outbox import Destination


def periodic(m: Module, command: str = "read i version") -> None:
    m.ok(f"write command 1 value|{command}|")
    m.ok("write date 20070301085959")
    m.ok("write message 1 start 20070301090000 period 000100")


def test_blocked_from_the_first_command_until_com_close(module: Module) -> None:
    periodic(module)
    assert run_for(module, 150) == []  # two triggers while blocked
    assert module.ask("write com close") == b"OK\r\n2.10\r\nOK\r\n"
    assert run_for(module, 60) == [(31.0, b"2.10\r\nOK\r\n")]  # 09:03:00


def test_a_reconnected_line_gets_the_waiting_message(module: Module) -> None:
    periodic(module)
    assert run_for(module, 90) == []
    module.engine.close_line(module.line)
    assert module.engine.next_deadline() is not None
    assert run_for(module, 10) == []  # no cable: the message waits for one
    fresh = module.engine.open_line()
    out = module.engine.advance(module.now)
    assert [(o.line, o.data) for o in out] == [(fresh, b"2.10\r\nOK\r\n")]


def test_every_line_without_a_command_gets_it(module: Module) -> None:
    periodic(module)
    released(module, "write i name/x/")
    other = module.engine.open_line()
    module.now += 1.0
    out = module.engine.advance(module.now)
    assert sorted(o.line for o in out) == sorted([module.line, other])
    assert {o.data for o in out} == {b"2.10\r\nOK\r\n"}
    module.engine.receive(other, b"read nothing\r", module.now)  # other sends a command
    assert run_for(module, 120) == []  # one blocking line holds messages for all


def test_body_numbered_by_counter_across_messages(module: Module) -> None:
    module.ok("write command 1 value|counter 2 read text/a/|")
    first = module.ask("write message 1 run 1 write com close")
    assert first == b"OK\r\n0,a\r\n1,OK\r\n"
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n2,a\r\n3,OK\r\n"
    assert module.ask("counter 2 read text/b/") == b"4,b\r\n5,OK\r\n"


def test_body_is_the_error_response_of_a_bad_command(module: Module) -> None:
    module.ok("write command 1 value|read bogus|")
    answer = module.ask("write message 1 run 1 write com close")
    assert answer == b"OK\r\nread bogus\r\nERROR\r\n"


def test_an_own_address_does_not_silence_messages(module: Module) -> None:
    module.ok("write command 1 value|read i name|")
    module.ok("write i name/ALA/ write i address/pw/")
    answer = module.ask("iaddress/pw/ write message 1 run 1 write com close")
    assert answer == b"OK\r\nALA\r\nOK\r\n"


def test_a_pause_in_the_command_delays_the_body(module: Module) -> None:
    module.ok("write command 1 value|pause 5 read i version|")
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n"
    assert run_for(module, 10) == [(5.0, b"2.10\r\nOK\r\n")]


def wavecom(m: Module) -> None:
    m.ok("write com device wavecom41")
    m.ok("write address 1 type sms 1 value/+420700000001/")
    m.ok("write address 2 type email 2 value/user@example.net/")
    m.ok("write address 3 type ringvoice 1 3 value/+420700000002/")
    m.ok("write address 4 type email 4 value/a@b.cz@u:p@smtp.b.cz:2525/")
    m.ok("write command 1 value|read i version|")


def test_wavecom_destinations_are_the_sms_and_email_addresses(module: Module) -> None:
    wavecom(module)
    module.ok("write message 1 address 1,2,3,4,5 write message 1 run 1")
    assert run_for(module, 1) == []  # nothing on the line: the modem carries it
    (outgoing,) = queued(module)
    assert outgoing.message == 1
    assert outgoing.body == "2.10\r\nOK\r\n"
    assert outgoing.destinations == (
        Destination("sms", "+420700000001"),
        Destination("email", "user@example.net"),
        Destination("email", "a@b.cz", "u:p@smtp.b.cz:2525"),
    )  # ringvoice and an address without a value are no destinations


def test_a_message_without_destinations_is_not_sent(module: Module) -> None:
    wavecom(module)
    module.ok("write message 1 address 3 write message 1 run 1")
    assert queued(module) == []


def test_messages_wait_while_the_modem_is_busy(module: Module) -> None:
    wavecom(module)
    module.engine.modem_busy = True
    module.ok("write message 1 run 1")
    run_for(module, 60)
    assert len(module.engine.outbox) == 0
    assert module.engine.next_deadline() is None  # nothing to do until the modem is free
    module.engine.modem_busy = False
    assert module.engine.next_deadline() is not None
    run_for(module, 0)
    assert [o.message for o in queued(module)] == [1]


def test_a_sending_with_its_carrier_holds_later_triggers(module: Module) -> None:
    wavecom(module)
    module.ok("write message 2 address 1")
    module.ok("write command 2 value|counter 1 read nothing|")
    module.ok("write message 2 command 2 write message 2 run 1")
    first = module.engine.outbox.take()
    assert first is not None and first.body == "0,OK\r\n"
    module.ok("write message 2 run 1")
    module.ok("write message 2 run 1")
    assert len(module.engine.outbox) == 0  # merged, waiting for the first to finish
    module.engine.outbox.done(first.ident, False)
    run_for(module, 0)
    assert [o.body for o in queued(module)] == ["1,OK\r\n"]


def test_ten_addresses_in_2_10(module: Module) -> None:
    wavecom(module)
    for n in range(5, 11):
        module.ok(f"write address {n} type sms {n} value/+42070000000{n - 5}/")
    module.ok("write message 40 address 1,2,3,4,5,6,7,8,9,10 write message 40 run 1")
    (outgoing,) = queued(module)
    assert outgoing.message == 40
    assert len(outgoing.destinations) == 9  # address 3 is ringvoice


def test_a_body_waiting_for_its_pause_waits_for_the_line_too(module: Module) -> None:
    module.ok("write command 1 value|pause 5 read i version|")
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n"
    module.ok("read nothing")  # blocked again before the pause is over
    module.advance(10)
    assert module.engine.next_deadline() is None  # no busy waiting while blocked
    assert module.ask("write com close") == b"OK\r\n2.10\r\nOK\r\n"


def test_a_change_committed_outside_a_step_is_scheduled(module: Module) -> None:
    # as a command received by SMS would commit it, through the interpreter alone
    periodic(module)
    released(module, "write message 1 period 000000")
    assert module.engine.next_deadline() is None
    answer = module.engine.interpreter.run_line("write message 1 period 000100", module.now)
    assert answer is not None and answer.data == b"OK\r\n"
    assert module.engine.next_deadline() == module.now + 1  # 09:00:00


def test_back_to_local_a_sending_no_modem_took_is_given_up(module: Module) -> None:
    wavecom(module)
    module.ok("write message 1 address 1 write message 1 run 1")
    assert len(module.engine.outbox) == 1  # no modem driver takes it
    module.ok("write com device local")
    assert len(module.engine.outbox) == 0
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n2.10\r\nOK\r\n"


def test_an_empty_or_silent_command_sends_nothing(module: Module) -> None:
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n"  # empty value
    module.ok("write command 1 value|quiet read nothing|")
    assert module.ask("write message 1 run 1 write com close") == b"OK\r\n"
