"""The whole suite's Hypothesis settings.

No per-example deadline: a deadline is a timed assertion, and on a loaded 2-core CI machine
an example that takes 267 ms instead of 200 ms says nothing about the code. Speed is measured
by the benchmarks in ``benchmarks/`` (DEVELOPERS.md), never by tests."""

from hypothesis import settings

settings.register_profile("sondalog", deadline=None)
settings.load_profile("sondalog")
