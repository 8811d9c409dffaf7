"""Parking for held robots (fleet/traffic/parking.py): through-flow and the parking cells in closed form on a
corridor, nearest-free assignment, and on the corridor world with admission `park`: held robots wait on parking
cells, off the corridor, and every robot still ends at its goal."""

from __future__ import annotations

import math
from pathlib import Path
from typing import cast

import numpy as np
import pytest
from scipy.sparse import csr_matrix

from fleet import FleetConfig, FleetService
from fleet.traffic import enable_traffic
from fleet.traffic.grid import TrafficGrid
from fleet.traffic.parking import Parking, parking_cells, through_flow
from planning.distance_fields import DistanceFields
from tests.fleet.test_traffic_corridor import STARTS, closest_pair_gap, corridor_world, spawn_swap_fleet


class Line:
    """A one-lane corridor of n cells 1 m apart (the parts of a TrafficGrid parking.py reads)."""

    def __init__(self, n: int) -> None:
        r = np.arange(n - 1)
        adj = csr_matrix((np.ones(2 * (n - 1)), (np.r_[r, r + 1], np.r_[r + 1, r])), shape=(n, n))
        self.fields = DistanceFields(adj)
        self.neighbours = [[u for u in (v - 1, v + 1) if 0 <= u < n] for v in range(n)]
        self.xy = np.column_stack([np.arange(n, dtype=float), np.zeros(n)])

    def __len__(self) -> int:
        return len(self.neighbours)


def test_through_flow_on_a_corridor_in_closed_form() -> None:
    n = 9
    flow = through_flow(cast(TrafficGrid, Line(n)), goals=n)
    v = np.arange(n)
    # goal left of v: the n-1-v nodes right of v pass through it; goal right of v: the v nodes left of it
    assert np.allclose(flow, 2 * v * (n - 1 - v) / n)


def test_parking_cells_are_the_quiet_ones_and_never_adjacent() -> None:
    line = cast(TrafficGrid, Line(9))
    flow = through_flow(line, goals=9)  # (0, 14, 24, 30, 32, 30, 24, 14, 0) / 9: median 24/9
    # the ends first; 1 and 7 touch them; 2 and 6 are at the median; 3, 4 and 5 above it
    assert parking_cells(line, flow) == [0, 2, 6, 8]


def test_assign_gives_the_nearest_free_cell_and_keeps_it() -> None:
    p = Parking(cast(TrafficGrid, Line(9)))
    assert p.cells.tolist() == [0, 2, 6, 8]
    assert p.assign("a", 5) == 6  # trips 5, 3, 1, 3 cells: the nearest (no goal given)
    assert p.assign("b", 7) == 8  # 6 is taken: trips 7, 5, 1
    assert p.assign("a", 0) == 6  # kept once given
    for k in "cd":
        p.assign(k, 0)
    assert p.assign("e", 4) == 4  # none free: where it is
    p.release("a")
    assert p.assign("e", 4) == 6


def test_assign_goes_towards_the_held_goal_within_the_slack() -> None:
    line = Line(9)
    to_goal = np.abs(np.arange(9) - 8.0)  # the held goal is cell 8
    p = Parking(cast(TrafficGrid, line))
    # from 4: trips 4, 2, 2, 4 (nearest 2, slack 3: all four); nearest the goal: 8, 4 cells away
    assert p.assign("a", 4, to_goal) == 8
    # from 1: trips 1, 1, 5 (8 is taken): within 1 + 3 only 0 and 2; of those 2 is nearer the goal
    assert p.assign("b", 1, to_goal) == 2
    # equally near the goal (goal 4: cells 2 and 6 both 2 away): the shorter trip
    assert p.assign("c", 7, np.abs(np.arange(9) - 4.0)) == 6


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("parking")


def test_held_robots_wait_on_parking_cells_and_every_goal_is_reached(tmp: Path) -> None:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = STARTS
        spawn_swap_fleet(svc)
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0, admission="park")
        adm, park = tm.admission, tm.parking
        assert adm is not None and park is not None
        adm.limit, adm.period_s, adm._next = 2, math.inf, math.inf  # a fixed limit: the AIMD step is tested apart
        flow = through_flow(tm.grid)
        assert flow[park.cells].max() <= np.median(flow)
        corridor = set(np.flatnonzero(np.abs(tm.grid.xy[:, 0]) < 2.0).tolist())  # the one-lane corridor, |x| < 2
        parked: set[int] = set()

        def go_all() -> None:
            for k, (x, y) in enumerate(starts):
                tm.add(f"r{k}")
                tm.go(f"r{k}", -x, y)  # to the mirror cell in the other room

        svc.call(go_all)
        worst = [np.inf]

        def check() -> None:
            for h in adm.queue:  # a held robot heads for, or waits on, its own parking cell
                i = tm.names.index(h.robot)
                assert int(tm.goal[i]) == park.cells[park.owner[h.robot]]
                if tm.a[i] == tm.b[i] == tm.goal[i]:
                    parked.add(int(tm.a[i]))
            worst[0] = min(worst[0], closest_pair_gap(svc, tm.radius))

        svc.step_listeners.append(check)
        t = 0.0
        while t < 600.0 and (tm.stats["reached"] < 8 or tm.active_count() or adm.queue):
            svc.advance(5.0)
            t += 5.0
        assert tm.stats["reached"] >= 8 and not adm.queue and not park.owner, tm.describe()
        assert parked and not parked & corridor  # robots did park, never in the one-lane corridor
        xy = np.array([[svc.world.robot_pose(f"r{k}").x, svc.world.robot_pose(f"r{k}").y] for k in range(8)])
        assert np.allclose(xy, [(-x, y) for x, y in starts], atol=0.15)
        assert worst[0] > 0.0
