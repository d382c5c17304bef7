"""What sends a message (§6.14): period and start, the month rule, new record rows, a channel
crossing a value with hysteresis, ``run 1``; triggers merging while a message waits.

Delivery here is ``com device local``: the body goes on the line as plain text (§6.14)."""

from __future__ import annotations

from ala1_module import Module
from messages_harness import bodies, released, run_for
from test_sampling import module_with, series


def dated(m: Module) -> None:
    m.ok("write date 20070301085959")  # one second before 09:00:00
    m.ok("write command 1 value/read date/")


def test_6_14_examples_byte_exact(module: Module, module116: Module) -> None:
    assert module.ask("read message max number") == b"40\r\nOK\r\n"
    assert module116.ask("read message max number") == b"2\r\nOK\r\n"
    assert module.ask("write message 1 period 240000") == b"OK\r\n"
    assert module.ask("write message of record function yes") == b"OK\r\n"
    assert module.ask("write message of channel function up") == b"OK\r\n"
    answer = module.ask("read message period of record function of channel function")
    assert answer == b"240000\r\nYES\r\nUP\r\nOK\r\n"


def test_periodic_message_from_its_start(module: Module) -> None:
    dated(module)
    released(module, "write message 1 start 20070301090000 period 000010")
    seen = run_for(module, 25)
    assert seen == [
        (1.0, b"20070301090000\r\nOK\r\n"),
        (11.0, b"20070301090010\r\nOK\r\n"),
        (21.0, b"20070301090020\r\nOK\r\n"),
    ]


def test_a_past_start_moves_forward_and_period_zero_is_off(module: Module) -> None:
    dated(module)
    released(module, "write message 1 start 20070301084500 period 001000")
    seen = run_for(module, 600)
    assert seen == [(301.0, b"20070301090500\r\nOK\r\n")]
    released(module, "write message 1 period 000000")
    assert run_for(module, 3600) == []


def test_monthly_period_on_the_last_day_of_short_months(module: Module) -> None:
    module.ok("write date 20070131115959")
    module.ok("write command 1 value/read date/")
    released(module, "write message 1 start 20070131120000 period 999901")
    seen = bodies(run_for(module, 120 * 86400))
    assert seen == [
        b"20070131120000\r\nOK\r\n",
        b"20070228120000\r\nOK\r\n",
        b"20070331120000\r\nOK\r\n",
        b"20070430120000\r\nOK\r\n",
    ]


def test_setting_the_clock_restarts_the_schedule(module: Module) -> None:
    dated(module)
    released(module, "write message 1 start 20070301090000 period 010000")
    released(module, "write date 20070301093000")
    seen = run_for(module, 3600)
    assert seen == [(1800.0, b"20070301100000\r\nOK\r\n")]


def test_of_record_once_per_sampling_instant_that_wrote_rows() -> None:
    m, _ = module_with(series((0, 1.0)))
    m.ok("write channel max number 2")
    m.ok("write channel 2 type 3 2 address 16 2 switch output 0")
    for ch in (1, 2):  # both channels sampled together: one row per instant
        m.ok(f"write channel {ch} sampling period 001000 {ch} sampling start 20070301090000")
    m.ok("write channel 2 record change -1")
    m.ok("write command 1 value/read record 100 from lastread shift/")
    released(m, "write message 3 command 1 of record function yes")
    seen = run_for(m, 1801)
    assert [t for t, _ in seen] == [1.0, 601.0, 1201.0, 1801.0]
    # local delivery succeeds at once: each message carries the rows since the last one
    assert seen[0][1] == b"20070301090000.0,1,1.00,\r\nOK\r\n"
    assert seen[1][1] == b"20070301091000.0,1,1.00,\r\nOK\r\n"


def test_of_record_ignores_instants_without_rows() -> None:
    m, _ = module_with(series((0, 1.0)))
    m.ok("write channel 1 sampling period 001000 sampling start 20070301090000")
    m.ok("write channel 1 record change -1")
    m.ok("write command 1 value/read date/")
    released(m, "write message of record function yes")
    assert run_for(m, 3601) == []


def crossing_module(function: str, steps: list[float], hysteresis: str = "0.10") -> Module:
    m, _ = module_with(series(*[(600 * i, v) for i, v in enumerate(steps)]))
    m.ok("write channel 1 sampling period 001000 sampling start 20070301090000")
    m.ok("write command 1 value/read channel 1 sample/")
    m.ok("write message 1 of channel number 1 of channel value 1.10")
    m.ok(f"write message 1 of channel hysteresis {hysteresis}")
    released(m, f"write message 1 of channel function {function}")
    return m


def test_of_channel_up_crosses_value_plus_half_the_hysteresis() -> None:
    # below 1.10; 1.15 is not above 1.10 + 0.05; 1.16 is; back to 1.06 is still above
    # 1.10 - 0.05, 1.04 goes below, 1.20 crosses up again
    steps = [1.00, 1.15, 1.16, 1.06, 1.20, 1.04, 1.20]
    seen = bodies(run_for(crossing_module("up", steps), 600 * len(steps)))
    assert seen == [b"1.16\r\nOK\r\n", b"1.20\r\nOK\r\n"]


def test_of_channel_down_crosses_value_minus_half_the_hysteresis() -> None:
    steps = [1.20, 1.05, 1.04, 1.14, 1.16, 1.06, 1.00]
    seen = bodies(run_for(crossing_module("down", steps), 600 * len(steps)))
    assert seen == [b"1.04\r\nOK\r\n", b"1.00\r\nOK\r\n"]


def test_the_first_sample_only_tells_the_side() -> None:
    steps = [1.50, 1.60]
    assert run_for(crossing_module("up", steps), 600 * len(steps)) == []


def test_run_1_sends_at_once(module: Module) -> None:
    module.ok("write command 2 value|read text/hello/|")
    module.ok("write message 2 command 2")
    answer = module.ask("write message 2 run 1 write com close")
    assert answer == b"OK\r\nhello\r\nOK\r\n"


def test_run_of_a_failed_line_sends_nothing(module: Module) -> None:
    module.ok("write command 1 value|read text/x/|")
    module.error("write message 1 run 1 write com close write bogus")
    assert run_for(module, 10) == []


def test_triggers_merge_while_the_message_waits(module: Module) -> None:
    dated(module)
    module.ok("write message 1 start 20070301090000 period 000010")
    assert run_for(module, 60) == []  # the line sent a command: blocked (§6.14.9.2)
    answer = module.ask("write com close")
    assert answer == b"OK\r\n20070301090059\r\nOK\r\n"  # six triggers, one sending


def test_message_2_in_1_16_and_its_single_address(module116: Module) -> None:
    module116.ok("write command 1 value/read i version/")
    module116.error("write message 3 run 1")
    module116.error("write message 2 address 1,2")
    assert module116.ask("write message 2 run 1 write com close") == b"OK\r\n1.16\r\nOK\r\n"


def test_without_hysteresis_the_value_itself_is_the_threshold() -> None:
    steps = [1.00, 1.10, 1.11, 1.10, 1.09, 1.11]
    seen = bodies(run_for(crossing_module("up", steps, "0"), 600 * len(steps)))
    assert seen == [b"1.11\r\nOK\r\n", b"1.11\r\nOK\r\n"]
