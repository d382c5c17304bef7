"""Each kind of alarm raises and clears (issue 21), with the observations' own times."""

from __future__ import annotations

from alarm_helpers import T0, plan_of, sample

from sondalog.collect.alarms import (
    Alarms,
    Cleared,
    Condition,
    Contact,
    Health,
    Raised,
    Sample,
)

THRESHOLD = """
[[alarm]]
name = "hot"
kind = "threshold"
logger = "F*"
channel = "Air"
above = 40
clear = 38
for = 3
"""


def feed(alarms: Alarms, values: list[float | None], logger: str = "F01") -> list[str]:
    """``raise@i`` / ``clear@i`` for the readings i = 0, 1, ... (one a minute)."""
    out = []
    for i, v in enumerate(values):
        for t in alarms.reading(sample(v, 60.0 * i, logger)):
            assert t.time == T0 + 60.0 * i  # the reading's own time
            out.append(f"{t.what}@{i}")
    return out


def test_threshold_needs_for_readings_and_clears_with_hysteresis() -> None:
    alarms = Alarms(plan_of(THRESHOLD))
    #          0   1   2   3   4   5   6   7   8   9   10  11
    values = [41, 42, 39, 41, 42, 43, 39, 39, 39, 37, 37, 37]
    # 41 42 39: broken run; 41 42 43 raises at 5; 39 39 39 are above clear (38): no clear
    assert feed(alarms, values) == ["raised@5", "cleared@11"]


def test_threshold_without_hysteresis_would_flap() -> None:
    """Values dancing around the limit raise once and never clear between 38 and 40."""
    alarms = Alarms(plan_of(THRESHOLD))
    values = [41, 41, 41] + [39.5, 40.5] * 20
    assert feed(alarms, values) == ["raised@2"]


def test_threshold_below_and_other_loggers_and_channels() -> None:
    alarms = Alarms(plan_of(THRESHOLD.replace("above = 40\nclear = 38", "below = 0\nclear = 2")))
    assert feed(alarms, [-1, -1, -1, 1, 3, 3, 3]) == ["raised@2", "cleared@6"]
    assert feed(alarms, [-1] * 5, logger="G01") == []  # not F*
    out = alarms.reading(Sample("s", "F02", 2, -5, T0, name="Soil"))
    assert out == []  # not the channel named Air


def test_old_rows_raise_and_clear_with_their_own_times() -> None:
    """A download of last week's rows, handed over long after: the transitions carry the
    rows' times, and a row seen again (a data message, then the download) counts once."""
    alarms = Alarms(plan_of(THRESHOLD))
    week_ago = -7 * 86400.0
    rows = [sample(v, week_ago + 600.0 * i) for i, v in enumerate([50, 50, 50, 30, 30, 30])]
    out = alarms.readings(rows)
    assert [(type(t), t.time) for t in out] == [
        (Raised, rows[2].time),
        (Cleared, rows[5].time),
    ]
    assert alarms.readings(rows) == []  # the same rows again: nothing
    assert alarms.readings([sample(50, week_ago)] * 5) == []  # older: ignored


def test_stuck() -> None:
    alarms = Alarms(plan_of('[[alarm]]\nkind = "stuck"\nchannel = 1\nfor = 4\n'))
    assert feed(alarms, [1, 2, 2, 2, 2, 2, 3, 3]) == ["raised@4", "cleared@6"]


def test_step() -> None:
    alarms = Alarms(plan_of('[[alarm]]\nkind = "step"\nchannel = 1\nstep = 5\nfor = 2\n'))
    assert feed(alarms, [10, 12, 20, 21, 30, 31, 32, 33]) == ["raised@2", "cleared@6"]
    [t] = Alarms(alarms.plan).readings([sample(1, 0), sample(9, 60)])
    assert "jumped from 1 to 9" in t.text


def test_none_values_are_ignored() -> None:
    alarms = Alarms(plan_of(THRESHOLD))
    assert feed(alarms, [41, None, 41, None, 41]) == ["raised@4"]


def test_no_contact_is_a_timer_of_the_source() -> None:
    alarms = Alarms(plan_of('[[alarm]]\nname = "silent"\nkind = "no_contact"\n'))
    alarms.watch_source("station-1", interval=60, now=T0)
    assert alarms.next_deadline() == T0 + 180  # 3 intervals
    assert alarms.advance(T0 + 179) == []
    alarms.contact(Contact("station-1", True, T0 + 100))
    assert alarms.next_deadline() == T0 + 280
    [raised] = alarms.advance(T0 + 1000)
    assert isinstance(raised, Raised) and raised.time == T0 + 280  # when it ran out
    assert raised.subject == "station-1" and alarms.next_deadline() is None
    assert alarms.advance(T0 + 2000) == []  # raised once
    alarms.contact(Contact("station-1", False, T0 + 2100, "refused"))
    [cleared] = alarms.contact(Contact("station-1", True, T0 + 2200))
    assert isinstance(cleared, Cleared) and cleared.time == T0 + 2200


def test_a_message_source_that_brought_nothing_is_no_contact_with_its_loggers() -> None:
    alarms = Alarms(plan_of('[[alarm]]\nkind = "no_contact"\nafter = 100\n'))
    alarms.watch_source("gsm-mail", interval=10, now=T0)
    # the mailbox answers, but the logger is out of coverage: nothing came
    assert alarms.contact(Contact("gsm-mail", True, T0 + 50, heard=False)) == []
    assert alarms.next_deadline() == T0 + 100  # not restarted
    [raised] = alarms.advance(T0 + 100)
    assert isinstance(raised, Raised)
    assert alarms.contact(Contact("gsm-mail", True, T0 + 150, heard=False)) == []
    [cleared] = alarms.contact(Contact("gsm-mail", True, T0 + 160))  # its held rows arrive
    assert isinstance(cleared, Cleared) and cleared.time == T0 + 160


def test_no_contact_after_and_last_contact_from_the_store() -> None:
    alarms = Alarms(plan_of('[[alarm]]\nkind = "no_contact"\nafter = "10m"\nsource = "st*"\n'))
    alarms.watch_source("station-1", interval=60, now=T0, last_contact=T0 - 500)
    alarms.watch_source("other", interval=60, now=T0)
    assert alarms.next_deadline() == T0 + 100
    assert [t.subject for t in alarms.advance(T0 + 100)] == ["station-1"]


def test_health_measures() -> None:
    text = """
[[alarm]]
kind = "health"
measure = "supply"
below = 11.5
clear = 12
[[alarm]]
kind = "health"
measure = "clock"
above = 30
[[alarm]]
kind = "health"
measure = "gaps"
"""
    alarms = Alarms(plan_of(text))

    def h(t: float, **values: float) -> list[str]:
        out = alarms.health(Health("station-1", T0 + t, "F01", **values))
        return [f"{x.what} {x.rule.split()[2]}" for x in out]

    assert h(0, supply=12.5, clock=-5, gaps=0) == []
    assert h(60, supply=11.4, clock=-45) == ["raised supply", "raised clock"]
    assert h(120, supply=11.8, gaps=3) == ["raised gaps"]  # 11.8: not yet cleared
    assert h(180, supply=12.1, clock=2, gaps=0) == [
        "cleared supply",
        "cleared clock",
        "cleared gaps",
    ]


def test_collector_conditions() -> None:
    text = """
[[alarm]]
kind = "collector"
watch = "sink"
after = 60
[[alarm]]
kind = "collector"
watch = "buffer"
above = 10
clear = 2
[[alarm]]
kind = "collector"
watch = "source"
for = 2
"""
    alarms = Alarms(plan_of(text))
    assert alarms.condition(Condition("sink", "postgres", 1, T0)) == []
    assert alarms.next_deadline() == T0 + 60
    [down] = alarms.advance(T0 + 61)
    assert down.rule == "collector sink *" and down.time == T0 + 60
    assert [t.what for t in alarms.condition(Condition("sink", "postgres", 0, T0 + 90))] == [
        "cleared"
    ]
    sizes = (5, 11, 5, 2)
    grow = [alarms.condition(Condition("buffer", "pg", n, T0 + i)) for i, n in enumerate(sizes)]
    assert [[t.what for t in g] for g in grow] == [[], ["raised"], [], ["cleared"]]
    refusing = [
        alarms.contact(Contact("station-1", ok, T0 + i, "refused"))
        for i, ok in enumerate([False, False, False, True])
    ]
    assert [[t.what for t in r] for r in refusing] == [[], ["raised"], [], ["cleared"]]


def test_acknowledge_and_states() -> None:
    alarms = Alarms(plan_of(THRESHOLD))
    feed(alarms, [41, 41, 41])
    [on] = alarms.active()
    assert on.state == "raised" and on.raised_at == T0 + 120
    ack = alarms.acknowledge(on.alarm, T0 + 500, by="ops")
    assert ack is not None and ack.event == on.event
    assert alarms.acknowledge(on.alarm, T0 + 501) is None  # once
    assert alarms.get(on.alarm).state == "acknowledged"  # type: ignore[union-attr]
    alarms.readings([sample(30, 600.0 * i) for i in range(1, 4)])
    record = alarms.get(on.alarm)
    assert record is not None and record.state == "cleared" and record.acked_at == T0 + 500
    assert alarms.active() == []


def test_export_and_import_neither_forget_nor_repeat() -> None:
    plan = plan_of(THRESHOLD)
    first = Alarms(plan)
    first.readings([sample(41, 0), sample(41, 60)])  # two of three
    again = Alarms(plan, first.export())
    assert [t.what for t in again.reading(sample(41, 120))] == ["raised"]  # counts kept
    after_restart = Alarms(plan, again.export())
    assert after_restart.readings([sample(41, 0), sample(41, 60), sample(41, 120)]) == []
    assert [a.state for a in after_restart.active()] == ["raised"]
    # a rule gone from the file: its alarms go too
    assert Alarms(plan_of('[[alarm]]\nkind = "stuck"\n'), again.export()).export() == []
