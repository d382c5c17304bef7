"""What modules with the same committed values share (issue 24: a fleet of 10,000 loggers).

Everything a module computes from its committed parameters alone (spec notes §3: the
values written so far, over the factory values of §6) is the same for every module of the
same version with the same values: factory values that depend on other values (§6.4.4.3:
a device's calibration by its type), the typed channel configurations (§6.5) and the
message configurations (§6.14). A fleet's loggers are mostly configured alike, so they
share one :class:`Derived` per distinct set of values instead of each computing and
holding its own: start-up builds each once, and the fleet holds each once.

A :class:`Derived` only grows with values computed from its key; a module that commits a
change takes the one of its new values (:func:`derived_for`). What reads the identity
(the serial number of ``i description``, §6.3.6) is not shared: the module keeps it itself
(``ModuleState.get``). The table is bounded (:data:`MAX_SHARED`): beyond it the oldest
entry leaves the table (the modules holding it keep it), so loggers configured one by one
cost what they cost before sharing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, TypeVar

from sondalog.ala1.model import Version

if TYPE_CHECKING:
    from sondalog.ala1.measure import ChannelConfig

T = TypeVar("T")

#: The most sets of values shared at once.
MAX_SHARED = 1024


class Derived:
    """What one set of committed values determines, shared by the modules that hold it."""

    __slots__ = ("configs", "memo", "settings")

    def __init__(self) -> None:
        #: Factory values that depend on other values (not on the identity).
        self.settings: dict[str, str] = {}
        #: Typed channel configurations (``ModuleState.channel_config``).
        self.configs: dict[int, ChannelConfig] = {}
        #: Other parts' values, by a key of their own (:meth:`shared`).
        self.memo: dict[str, object] = {}

    def shared(self, key: str, make: Callable[[], T]) -> T:
        """``make()``, computed once for every module with these values: ``make`` must read
        committed values only (not the identity, the clock or the hardware), and return
        something nobody changes."""
        try:
            return self.memo[key]  # type: ignore[return-value]
        except KeyError:
            value = self.memo[key] = make()
            return value


_TABLE: dict[tuple[Version, str, frozenset[tuple[str, str]]], Derived] = {}


def derived_for(version: Version, device: str, values: Mapping[str, str]) -> Derived:
    """The :class:`Derived` of a module of ``version`` and ``device`` with ``values``."""
    key = (version, device, frozenset(values.items()))
    found = _TABLE.get(key)
    if found is None:
        if len(_TABLE) >= MAX_SHARED:
            del _TABLE[next(iter(_TABLE))]  # the oldest (dicts keep insertion order)
        found = _TABLE[key] = Derived()
    return found
