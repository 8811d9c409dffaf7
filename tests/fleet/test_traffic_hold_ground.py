"""Robots in a wait hold their ground (pibt.py `hold_ground`, priority.holding_ground, the layer's `hold_ground_s`):
PIBT's rule in closed form on a small map (a marked robot is pushed on or aside, never back; its pusher waits
instead), which robots the layer marks, and the setting's check."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import PIBT, TrafficManager, enable_traffic
from sim import FleetError, Pose2D
from tests.fleet.test_traffic_corridor import corridor_world
from tests.fleet.test_traffic_crossings import plan
from tests.fleet.test_traffic_jam import grid

LINE = ["....", "#.##"]  # an aisle (0..3, 1) with a side cell (1, 0) below its second cell


def line() -> tuple[dict[tuple[int, int], int], PIBT]:
    neighbours, fields, node = grid(LINE, lanes=False)
    return node, PIBT(neighbours, fields.to, seed=0)


def test_a_robot_holding_its_ground_is_not_pushed_back() -> None:
    node, pibt = line()
    # p heads east from (0, 1); q stands in (1, 1) bound west, for (0, 1): every free cell but p's is farther
    robots = {"p": ((0, 1), (3, 1), 5.0), "q": ((1, 1), (0, 1), 1.0)}
    assert plan(pibt, node, robots) == {"p": (1, 1), "q": (1, 0)}  # PIBT: q is pushed aside, one farther
    pibt.hold_ground = np.array([False, True])
    assert plan(pibt, node, robots) == {"p": (0, 1), "q": (1, 1)}  # q holds: the push fails and p waits
    assert pibt.pushes == [(0, 1)]  # tried, then backtracked
    pibt.hold_ground = np.array([True, False])  # only the pusher marked: the rule is about being pushed
    assert plan(pibt, node, robots) == {"p": (1, 1), "q": (1, 0)}


def test_a_robot_holding_its_ground_is_still_pushed_on_or_aside() -> None:
    node, pibt = line()
    pibt.hold_ground = np.array([False, True])
    # q bound east too: the cell ahead is closer to its goal, so the push moves it on
    assert plan(pibt, node, {"p": ((0, 1), (3, 1), 5.0), "q": ((1, 1), (3, 1), 1.0)}) == {"p": (1, 1), "q": (2, 1)}
    # q bound for the side cell (1, 0): stepping aside brings it closer, so the push moves it there
    assert plan(pibt, node, {"p": ((0, 1), (3, 1), 5.0), "q": ((1, 1), (1, 0), 1.0)}) == {"p": (1, 1), "q": (1, 0)}


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("hold_ground")


@pytest.mark.parametrize(("hold_ground_s", "urgent_s"), [(5.0, 10.0), (None, 10.0), (5.0, None)])
def test_the_layer_marks_robots_in_a_wait_that_are_not_urgent(tmp: Path, hold_ground_s: float | None,
                                                              urgent_s: float | None) -> None:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = {"r0": (-4.5, 1.5), "r1": (-4.5, -1.5), "r2": (4.5, 1.5), "r3": (4.5, -1.5)}
        for name, (x, y) in starts.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0, urgent_s=urgent_s, admission="off",
                            hold_ground_s=hold_ground_s)

        def setup() -> np.ndarray | None:
            for name in starts:
                tm.add(name)
            now = svc.world.time
            for name, (x, y) in (("r0", (-2.5, 1.5)), ("r1", (-2.5, -1.5)), ("r2", (2.5, 1.5))):
                tm.go(name, x, y)  # r3 has no goal
            tm.best_at[tm._idx["r0"]] = now - 6.0  # in a wait for 6 s: holds its ground
            tm.best_at[tm._idx["r1"]] = now - 4.0  # 4 s: not yet
            tm.best_at[tm._idx["r2"]] = now - 12.0  # 12 s: urgent (aging at 10 s) and pushed like any
            tm._plan(now)
            return tm.pibt.hold_ground

        marked = svc.call(setup)
        if urgent_s is None:  # without aging nothing would end a hold: the rule is off
            assert marked is None and not np.isfinite(tm.urgent_at).any()
            return
        assert math.isfinite(tm.urgent_at[tm._idx["r2"]])
        if hold_ground_s is None:
            assert marked is None
        else:
            assert marked is not None and marked.tolist() == [True, False, False, False]


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf])
def test_hold_ground_s_is_checked(tmp: Path, bad: float) -> None:
    config = FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)
    with FleetService(config) as svc, pytest.raises(FleetError, match="hold_ground_s"):
        svc.call(lambda: TrafficManager(svc, hold_ground_s=bad))
