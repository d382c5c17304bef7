"""The record memory (§6.6, §9, spec notes §6): invariants, status, points, persistence."""

from __future__ import annotations

from pathlib import Path

from ala1_module import Module
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.ala1.record import RecordMemory, row_key

texts = st.text(st.characters(min_codepoint=97, max_codepoint=122), min_size=0, max_size=40)


def small(capacity: int, cyclic: bool) -> Module:
    m = Module()
    m.ok("write date 20070301090000")
    m.ok(f"write file record size {capacity}")
    m.ok(f"write record type {'cyclic' if cyclic else 'linear'}")
    return m


def full_read(m: Module) -> bytes:
    answer = m.ask("read record 1000000 from start")
    assert answer.endswith(b"OK\r\n")
    return answer[: -len(b"OK\r\n")]


@settings(max_examples=60, deadline=None)
@given(st.lists(texts, max_size=60), st.booleans(), st.sampled_from([256, 512, 1024]))
def test_status_counts_the_bytes_of_a_full_read(words: list[str], cyclic: bool, size: int) -> None:
    m = small(size, cyclic)
    for i, word in enumerate(words):
        m.now += i % 3  # some rows share a second
        m.ask(f"write text/{word}/")
    status = m.read("read record status")
    chars, fraction, state = status.split(",")
    body = full_read(m)
    if state == "FULL" and cyclic:
        assert status == "0,1.00,FULL"  # the §6.6.5 quirk
    else:
        assert int(chars) == len(body)
        assert state == "CLEAR" if not body else state in ("FILLING", "FULL")
        assert fraction == f"{int(len(body) * 100 / size + 0.5) / 100:.2f}" or state == "FULL"
    assert len(body) <= size


@settings(max_examples=60, deadline=None)
@given(st.lists(texts, min_size=1, max_size=80))
def test_cyclic_record_keeps_the_newest_rows(words: list[str]) -> None:
    m = small(512, cyclic=True)
    for word in words:
        m.ask(f"write text/{word}/")
        m.now += 1
    kept = full_read(m).decode().split("\r\n")[:-1]
    stored = [row.split(",", 2)[2] for row in kept]
    assert stored == words[len(words) - len(stored) :]  # a suffix: the newest rows
    assert sum(len(r) + 2 for r in kept) <= 512
    if len(stored) < len(words):  # something was dropped: nothing else would have fitted
        dropped = words[len(words) - len(stored) - 1]
        assert sum(len(r) + 2 for r in kept) + len(dropped) + 24 > 512


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(1, 7), min_size=1, max_size=12), st.integers(1, 4))
def test_shift_reads_return_every_row_exactly_once(batches: list[int], point: int) -> None:
    m = small(1048576 - 256 * 0, cyclic=True)
    written: list[str] = []
    got: list[str] = []
    for batch, count in enumerate(batches):
        for i in range(count):
            m.ask(f"write text/{batch}-{i}/")
            written.append(f"{batch}-{i}")
            m.now += batch % 2
        answer = m.ask(f"read record 3 from last {point} read shift").decode()
        got += [r.split(",", 2)[2] for r in answer.split("\r\n")[:-2]]
    while True:
        answer = m.ask(f"read record 3 from last {point} read shift").decode()
        more = [r.split(",", 2)[2] for r in answer.split("\r\n")[:-2]]
        if not more:
            break
        got += more
    assert got == written


def test_hold_leaves_the_point_and_points_are_independent() -> None:
    m = small(4096, cyclic=True)
    for word in "abcde":
        m.ask(f"write text/{word}/")
    assert m.ask("read record 2 from last read hold").count(b"\r\n") == 3
    assert m.read("read record last read") == ""
    m.ask("read record 2 from last 2 read shift")
    assert m.read("read record last 2 read") == "20070301090000.1"
    assert m.ask("read record 9 from last 2 read hold").decode().split("\r\n")[0].endswith("c")
    m.ok("write record last 3 read/20070301090000.3/")
    assert m.ask("read record 9 from last 3 read shift") == b"20070301090000.4,3,e\r\nOK\r\n"


def test_linear_record_refuses_rows_that_do_not_fit() -> None:
    m = small(256, cyclic=False)
    for i in range(20):
        m.ok(f"write text/row {i:02d}/")
    body = full_read(m)
    assert m.read("read record status") == f"{len(body)},1.00,FULL"
    assert body.endswith(b",3,row 08\r\n")  # nine rows of 25 characters + CR LF fit in 256
    m.ok("write record status clear")
    assert m.read("read record status") == "0,0.00,CLEAR"


def test_cyclic_quirk_until_cleared() -> None:
    m = small(256, cyclic=True)
    for i in range(11):
        m.ok(f"write text/row {i:02d}/")
    assert m.read("read record status") == "0,1.00,FULL"
    m.ok("write record status clear")
    m.ok("write text/x/")
    assert m.read("read record status") == "22,0.09,FILLING"


def test_record_type_changes_only_while_empty() -> None:
    m = small(4096, cyclic=True)
    m.ok("write text/x/")
    m.error("write record type linear")
    m.ok("write record type cyclic")  # the same type is fine
    m.ok("write record status clear")
    m.ok("write record type linear")


def test_partition_and_global_reset_erase_the_record() -> None:
    m = small(4096, cyclic=True)
    m.ok("write text/x/")
    m.ok("write file record size 8192")
    assert full_read(m) == b""
    m.ok("write text/y/")
    m.ok("write global reset")
    assert full_read(m) == b""
    assert m.read("read record status") == "0,0.00,CLEAR"


def test_a_failing_line_stores_no_row() -> None:
    m = small(4096, cyclic=True)
    m.error("write text/x/ write bogus")
    assert full_read(m) == b""


def test_rows_survive_a_restart_and_the_counter_continues(tmp_path: Path) -> None:
    db = tmp_path / "ala1.sqlite"
    first = Module(db=db)
    first.ok("write date 20070301090000")
    first.ok("write file record size 1280")
    for i in range(40):
        first.ok(f"write text/row {i}/")
    before = full_read(first)
    status = first.read("read record status")
    first.store.close()
    second = Module(db=db, now=first.now)
    assert full_read(second) == before
    assert second.read("read record status") == status
    second.ok("write text/after/")
    assert full_read(second).endswith(b"20070301090000.Z,3,after\r\n")  # counter capped at Z


def test_record_memory_rollback_restores_dropped_rows() -> None:
    memory = RecordMemory([], 0, 100, cyclic=True)
    for i in range(3):
        memory.append("20070301090000", f"3,{'x' * 10}{i}")
    memory.take_changes()
    mark = memory.mark()
    memory.append("20070301090001", "3," + "y" * 60)
    assert len(memory) == 1
    memory.rollback(mark)
    assert [row_key(r) for r in memory.rows()] == [
        "20070301090000.0",
        "20070301090000.1",
        "20070301090000.2",
    ]
    assert memory.take_changes() is None


def test_module_clock_never_runs_back_after_an_accelerated_restart(tmp_path: Path) -> None:
    db = tmp_path / "ala1.sqlite"
    first = Module(db=db)
    first.ok("write date 20070301090000")
    first.now += 7200  # an accelerated clock ran two hours ahead of the wall clock
    first.ok("write text/last/")
    first.store.close()
    second = Module(db=db, now=first.now - 7000)  # restarted: the wall clock is behind
    assert second.read("read date") == "20070301110000"
    second.ok("write text/next/")
    rows = full_read(second).decode().split("\r\n")
    assert rows[0] < rows[1]
