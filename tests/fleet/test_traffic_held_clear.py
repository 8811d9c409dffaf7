"""Held robots keep off the ways of robots in a wait (fleet/traffic/admission_wait.py `held_off_ways`, pibt.py
`keep_off`, the layer's `held_clear`): PIBT's rule in closed form on a small map (a held robot plans no move of its
own into a hot cell, may leave one, and is still pushed into one), and the layer's wiring on the corridor world."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import PIBT, enable_traffic
from fleet.traffic.admission_wait import BoundAdmission, held_off_ways
from sim import Pose2D
from tests.fleet.test_traffic_corridor import corridor_world
from tests.fleet.test_traffic_crossings import plan
from tests.fleet.test_traffic_jam import JUNCTIONS, grid


def left_stub() -> tuple[dict[tuple[int, int], int], PIBT]:
    """JUNCTIONS without lanes: the one-lane stub x = 0, y 6–7 joins the top-left aisle to the middle one."""
    neighbours, fields, node = grid(JUNCTIONS, lanes=False)
    return node, PIBT(neighbours, fields.to, seed=0)


def test_a_held_robot_plans_no_move_of_its_own_into_a_hot_cell() -> None:
    node, pibt = left_stub()
    robots = {"h": ((0, 8), (0, 4), 1.0)}  # down the stub: (0, 7) is its only way closer
    assert plan(pibt, node, robots)["h"] == (0, 7)
    pibt.keep_off, pibt.hot = np.array([True]), {node[(0, 7)]}
    assert plan(pibt, node, robots)["h"] == (0, 8)  # kept off: it waits where it is, every other cell is farther
    pibt.keep_off = np.array([False])  # not held (an active robot): the rule does not apply
    assert plan(pibt, node, robots)["h"] == (0, 7)
    pibt.keep_off, pibt.hot = np.array([True]), {node[(0, 8)]}  # standing in a hot cell, it may leave it
    assert plan(pibt, node, {"h": ((0, 8), (0, 4), 1.0)})["h"] == (0, 7)


def test_a_held_robot_is_still_pushed_into_a_hot_cell() -> None:
    node, pibt = left_stub()
    # p climbs the stub to (0, 9); h, held, stands in the stub ahead of it: its only cell off p's way is up, hot
    robots = {"p": ((0, 6), (0, 9), 5.0), "h": ((0, 7), (0, 7), 0.0)}
    pibt.keep_off, pibt.hot = np.array([False, True]), {node[(0, 8)]}
    nxt = plan(pibt, node, robots)
    assert nxt == {"p": (0, 7), "h": (0, 8)}  # pushed: p keeps its way, so no push chain loses one
    assert pibt.pushes == [(0, 1)]


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("held_clear")


@pytest.mark.parametrize("held_clear", [True, False])
def test_layer_marks_held_robots_and_the_starved_way(tmp: Path, held_clear: bool) -> None:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = {"r0": (-2.5, 0.5), "r1": (-4.5, -1.5), "r2": (-4.5, 1.5)}
        for name, (x, y) in starts.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0, held_clear=held_clear)
        adm = tm.admission
        assert isinstance(adm, BoundAdmission)
        adm.limit, adm._next = 1, math.inf

        def setup() -> tuple[np.ndarray | None, set[int]]:
            for name in starts:
                tm.add(name)
            tm.go("r0", 2.5, 0.5)  # through the corridor: started
            tm.go("r1", 4.5, -1.5)  # held
            tm.best_at[tm._idx["r0"]] = svc.world.time - 15.0  # r0 in a wait for 15 s
            tm._admit(svc.world.time)
            tm._plan(svc.world.time)
            return tm.pibt.keep_off, set(tm.pibt.hot)

        keep_off, hot = svc.call(setup)
        corridor = tm.grid.node_at(0.5, 0.5)
        assert tm.held("r1") and corridor in adm.hot  # the corridor lies on r0's way
        mask, cells = held_off_ways(tm)
        assert mask is not None and mask.tolist() == [False, True, False] and cells == adm.hot
        if held_clear:
            assert keep_off is not None and keep_off.tolist() == [False, True, False] and hot == adm.hot
        else:
            assert keep_off is None and hot == set()
        svc.call(lambda: tm.best_at.__setitem__(tm._idx["r0"], svc.world.time))  # r0 came closer: no wait
        svc.call(lambda: tm._admit(svc.world.time))
        assert held_off_ways(tm) == (None, set())  # nothing hot: nobody is kept off
