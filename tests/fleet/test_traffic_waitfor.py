"""The traffic layer's wait-for graph (fleet/traffic/waitfor.py): cycles and queues told apart in closed form,
and the naive planner's head-on jam in a one-lane corridor (tests/fleet/test_traffic_corridor.py) is a cycle."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet.traffic.waitfor import reaches_cycle, wait_for_edges
from tests.fleet.test_traffic_corridor import run


def test_reaches_cycle_closed_form() -> None:
    # 0 → 1 → 2 → 0 a cycle, 3 behind it; 4 → 5 → 6 a queue ending at 6; 7 waits for itself; 8 alone.
    edges = [(0, 1), (1, 2), (2, 0), (3, 0), (4, 5), (5, 6), (7, 7)]
    got = reaches_cycle(9, edges)
    assert got.tolist() == [True, True, True, True, False, False, False, True, False]
    assert not reaches_cycle(3, []).any()
    # a chain that branches: one branch into a cycle is enough (an over-approximation of deadlock)
    assert reaches_cycle(5, [(0, 1), (0, 2), (2, 3), (3, 2)]).tolist() == [True, False, True, True, False]


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("waitfor")


def test_naive_corridor_jam_is_a_cycle(tmp: Path) -> None:
    tm, _, _, _ = run(tmp, naive=True, seconds=80.0)
    stuck = [tm._idx[n] for n in tm.open_stalls]
    assert stuck
    edges = wait_for_edges(tm)
    on = reaches_cycle(len(tm.names), edges)
    assert on[stuck].all(), (edges, stuck)
    assert all(0 <= i < len(tm.names) and 0 <= k < len(tm.names) and i != k for i, k in edges)

