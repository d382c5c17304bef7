"""Random valid values of a station-file setting, typed as a technician would: one strategy
per grammar, shared by the round-trip and the configuration-read tests (each gives its own
numbers and strings)."""

from __future__ import annotations

from collections.abc import Callable

from hypothesis import strategies as st

from sondalog.client import station_grammar as g
from sondalog.client.station_schema import Setting


def values(
    setting: Setting,
    limits: g.Limits,
    *,
    number: st.SearchStrategy[str],
    text: Callable[[int | None], st.SearchStrategy[str]],
) -> st.SearchStrategy[str]:
    """Values of ``setting`` under ``limits``; ``number`` for a number, ``text(max_len)``
    for a string (a rest-of-line gets ``/`` before a text that is not blank)."""
    grammar = setting.grammar
    match grammar:
        case g.Integer():
            return st.integers(grammar.lo, min(g._bound(grammar.hi, limits), 10**6)).map(str)
        case g.ChannelAddress():
            return st.integers(0, limits.channel_address_max).map(str)
        case g.MemorySize():
            return st.integers(grammar.minimum // 256, 4096).map(lambda k: str(k * 256))
        case g.OneOf():
            return st.sampled_from(grammar.options).map(str)
        case g.Choice():
            return st.sampled_from(grammar.options).map(
                lambda o: f"{o},1" if o in dict(grammar.with_arg) else o
            )
        case g.Number():
            return number
        case g.Format():
            return st.tuples(st.integers(0, 9), st.integers(0, 9)).map(lambda t: f"{t[0]}.{t[1]}")
        case g.Date():
            return st.datetimes().map(lambda d: d.strftime("%Y%m%d%H%M%S"))
        case g.Period():
            return st.tuples(st.integers(0, 95), st.integers(0, 59), st.integers(0, 59)).map(
                lambda t: f"{t[0]:02d}{t[1]:02d}{t[2]:02d}"
            )
        case g.IntList():
            return st.lists(
                st.integers(1, limits.addresses), min_size=1, max_size=limits.addresses_per_message
            ).map(lambda items: ",".join(map(str, items)))
        case g.OutputValue():
            return st.sampled_from(["0", "1", "NO"])
        case g.RestOfLine():
            return text(20).filter(lambda t: t.strip() != "").map(lambda t: "/" + t)
    return text(getattr(grammar, "max_len", None))
