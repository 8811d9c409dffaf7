"""Shared fixtures for sim tests: small real worlds (no fakes)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from sim import World


@pytest.fixture
def world() -> Iterator[World]:
    w = World(physics_hz=100, seed=3)
    yield w
    w.close()
