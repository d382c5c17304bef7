"""gsm.md §7 searched, not tried: a few hundred random schedules of SMS, calls, coverage,
messages, mail and a slow modem line, each followed by quiet and the liveness properties
(:mod:`liveness_machine`). ``benchmarks/soak_gsm.py`` runs thousands."""

from __future__ import annotations

import os

from hypothesis import HealthCheck, Phase, settings
from liveness_machine import GsmLiveness

GsmLiveness.TestCase.settings = settings(
    max_examples=int(os.environ.get("SONDALOG_LIVENESS_EXAMPLES", "300")),
    stateful_step_count=25,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=True,
    phases=[Phase.explicit, Phase.generate, Phase.shrink],
)
TestGsmLiveness = GsmLiveness.TestCase
