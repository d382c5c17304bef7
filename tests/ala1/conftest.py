"""Fixtures of the ALA1 core tests (the harness is in ala1_module.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from ala1_module import Module

from sondalog.ala1 import Version


@pytest.fixture
def module() -> Iterator[Module]:
    m = Module()
    yield m
    m.store.close()


@pytest.fixture
def module116() -> Iterator[Module]:
    m = Module(Version.V1_16)
    yield m
    m.store.close()
