"""Pure pieces: record rows -> readings, and the export files' resume and repair."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sondalog.client.records import Channel, RowError, make_key, parse_key, parse_row, split_name
from sondalog.collect.export import CsvExport, ExportError, JsonlExport, open_export
from sondalog.collect.readings import rows_to_readings


def test_rows() -> None:
    row = parse_row("20070301120000.3,1,12.4,,-0.800")
    assert (row.key, row.time, row.counter, row.type) == (
        "20070301120000.3",
        datetime(2007, 3, 1, 12),
        3,
        1,
    )
    assert row.values == (12.4, None, -0.8) and row.text is None
    text = parse_row("20070301120001.Z,3,a, b,c")
    assert (text.counter, text.type, text.text) == (35, 3, "a, b,c")
    typed = parse_row("20070301120001.0,1,abc")  # write text 1/abc/ (spec notes §6)
    assert typed.text == "abc" and typed.type == 1
    assert parse_row("20070301120001.0,5").text == ""
    for bad in (
        "",
        "OK",
        "20070301120000.3",
        "2007030112000.3,1,1",
        "20070230120000.0,1,1",
        "20070301120000.0,x,1",
    ):
        with pytest.raises(RowError):
            parse_row(bad)


@given(st.datetimes(datetime(2000, 1, 1), datetime(2099, 12, 31)), st.integers(0, 35))
def test_keys_round_trip_and_sort_like_time(when: datetime, counter: int) -> None:
    when = when.replace(microsecond=0)
    key = make_key(when, counter)
    assert parse_key(key) == (when, counter)
    later = make_key(when, counter + 1) if counter < 35 else None
    assert later is None or later > key


def test_names_units_and_readings() -> None:
    assert split_name("Supply[V]") == Channel("Supply", "V")
    assert split_name("Teplota vzduchu [°C]") == Channel("Teplota vzduchu", "°C")
    assert split_name("Hladina") == Channel("Hladina")
    assert split_name("[V]") == Channel("[V]")
    rows = [parse_row("20070301120000.0,1,12.4,,1.5"), parse_row("20070301120000.1,3,door open")]
    out = rows_to_readings(rows, "000007", {1: Channel("Supply", "V")}, ZoneInfo("Europe/Prague"))
    assert [(r.channel, r.value, r.text, r.name, r.unit) for r in out] == [
        (1, 12.4, None, "Supply", "V"),
        (3, 1.5, None, None, None),
        (0, None, "door open", None, None),
    ]
    assert out[0].utc is not None and out[0].utc.isoformat() == "2007-03-01T11:00:00+00:00"


def _readings(first: int, count: int) -> list:  # type: ignore[type-arg]
    rows = [
        parse_row(f"20070301{12 + i // 3600:02d}{i // 60 % 60:02d}{i % 60:02d}.0,1,{i}.5,1")
        for i in range(first, first + count)
    ]
    return rows_to_readings(rows, "000001")


@pytest.mark.parametrize("suffix", [".csv", ".jsonl"])
def test_resume_point_and_torn_tail(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"d{suffix}"
    export = open_export(path)
    assert (export.logger, export.cursor) == (None, None)
    export.append(_readings(0, 10))
    export.close()
    export = open_export(path)
    assert (export.logger, export.cursor, export.repaired) == ("000001", "20070301120009.0", None)
    export.close()
    whole = path.read_bytes()
    path.write_bytes(whole[:-7])  # a crash in the middle of the last line
    export = open_export(path)
    assert export.cursor == "20070301120009.0"  # row 9 is read again ...
    assert export.held_last == {("20070301120009.0", 1)}  # ... for its channel 2
    assert export.repaired is not None and export.repaired.startswith("a torn last line")
    export.append([r for r in _readings(9, 1) if r.channel == 2])
    export.close()
    assert path.read_bytes() == whole


def test_refusals(tmp_path: Path) -> None:
    with pytest.raises(ExportError, match=r"unknown format '\.txt'"):
        open_export(tmp_path / "x.txt")
    (tmp_path / "x.jsonl").write_text('{"a": 1}\n')
    with pytest.raises(ExportError, match="not a sondalog JSON lines export"):
        JsonlExport(tmp_path / "x.jsonl")
    (tmp_path / "x.csv").write_text("logger,time,counter,type,channel,value\n")
    with pytest.raises(ExportError, match="not a sondalog CSV export"):
        CsvExport(tmp_path / "x.csv")
    assert (tmp_path / "x.csv").read_text() == "logger,time,counter,type,channel,value\n"


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.integers(1, 6), min_size=1, max_size=5),
    st.integers(0, 400),
    st.sampled_from([".csv", ".jsonl"]),
)
def test_any_crash_tear_then_resume_gives_every_line_once(
    tmp_path_factory: pytest.TempPathFactory, chunks: list[int], cut: int, suffix: str
) -> None:
    """Chunks appended, the file torn anywhere in its last bytes, reopened, the rest read again
    from the cursor: the file ends up exactly as if nothing had happened."""
    path = tmp_path_factory.mktemp("tear") / f"d{suffix}"
    everything = _readings(0, sum(chunks))
    export = open_export(path)
    done = 0
    for size in chunks:
        export.append(_readings(done, size))
        done += size
    export.close()
    whole = path.read_bytes()
    path.write_bytes(whole[: max(len(whole) - cut, 0)])
    export = open_export(path)
    cursor = export.cursor or ""
    rest = [  # what the download appends: from the last row held, lines not held
        r
        for r in everything
        if make_key(r.time, r.counter) >= cursor
        and (make_key(r.time, r.counter), r.channel) not in export.held_last
    ]
    export.append(rest)
    export.close()
    assert path.read_bytes() == whole
