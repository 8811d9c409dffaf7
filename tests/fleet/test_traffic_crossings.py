"""Crossings kept clear (fleet/traffic/crossings.py, pibt.py `box`): the crossing cells of a small warehouse in closed
form, and PIBT's rule on one of them: a robot planning its own move enters only with a way out towards its goal,
unless it is urgent or has waited `keep_clear_s` at rest (the layer, aging off)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import PIBT, TrafficManager, enable_traffic
from fleet.traffic.crossings import crossing_cells
from sim import Pose2D
from sim.errors import FleetError
from tests.fleet.test_traffic_async import Truth, world
from tests.fleet.test_traffic_jam import JUNCTIONS, grid

URGENT = 1e9


def junctions() -> tuple[list[list[int]], dict[tuple[int, int], int], PIBT]:
    neighbours, fields, node = grid(JUNCTIONS, lanes=False)
    pibt = PIBT(neighbours, fields.to, seed=0)
    ij = np.array(sorted(node, key=node.__getitem__))
    pibt.box, pibt.box_exempt = crossing_cells(ij, neighbours), URGENT
    return neighbours, node, pibt


def test_crossing_cells_are_the_blocks_where_two_lane_aisles_meet() -> None:
    _, node, pibt = junctions()
    # the centre aisle (x 4-5) crosses the middle aisle (y 4-5) in a 2 x 2 block and meets the top and bottom ones
    # (y 8-9, y 0-1) in T-junctions, whose inner row has four neighbours; the one-lane end columns have three
    expected = {(4, 4), (5, 4), (4, 5), (5, 5), (4, 8), (5, 8), (4, 1), (5, 1)}
    assert pibt.box == {node[c] for c in expected}
    room = np.array([(i, j) for i in range(6) for j in range(4)])  # open floor: every diagonal free
    nb = [[k for k, (a, b) in enumerate(room.tolist()) if abs(a - i) + abs(b - j) == 1] for i, j in room.tolist()]
    assert crossing_cells(room, nb) == set()


def plan(pibt: PIBT, node: dict[tuple[int, int], int], robots: dict[str, tuple[tuple[int, int], tuple[int, int], float]]
         ) -> dict[str, tuple[int, int]]:
    """One PIBT step: robots name -> (cell, goal, priority); returns each robot's next cell."""
    names = list(robots)
    cells = {v: k for k, v in node.items()}
    nxt = pibt.step([node[robots[n][0]] for n in names], [node[robots[n][1]] for n in names],
                    np.array([robots[n][2] for n in names]))
    return {n: cells[v] for n, v in zip(names, nxt, strict=True)}


def test_a_robot_waits_outside_a_crossing_whose_exit_is_held() -> None:
    _, node, pibt = junctions()
    # a heads east along the middle aisle through the crossing (4, 4) - (5, 4); b stands idle in the exit (5, 4)
    robots = {"a": ((3, 4), (9, 4), 5.0), "b": ((5, 4), (5, 4), 0.0)}
    assert plan(pibt, node, robots)["a"] == (3, 4)  # no way out: it waits outside, its own lane only
    pibt.box_for = np.array([False, True])  # a not on a task (the layer: an idle robot going back to its cell)
    assert plan(pibt, node, robots)["a"] == (4, 4)
    pibt.box_for = None
    pibt.box = set()
    assert plan(pibt, node, robots)["a"] == (4, 4)  # without the rule it enters and blocks the crossing


def test_it_enters_once_the_exit_is_planned_free_or_when_urgent() -> None:
    _, node, pibt = junctions()
    # b, planned first, leaves the exit east: a follows it into the crossing
    leaving = {"a": ((3, 4), (9, 4), 5.0), "b": ((5, 4), (9, 5), 9.0)}
    moves = plan(pibt, node, leaving)
    assert moves["b"] != (5, 4) and moves["a"] == (4, 4)
    # urgent, a enters although b holds the exit (it will push b from there)
    held = {"a": ((3, 4), (9, 4), URGENT + 3.0), "b": ((5, 4), (5, 4), 0.0)}
    assert plan(pibt, node, held)["a"] == (4, 4)
    # a robot whose goal is the crossing cell itself needs no way out
    assert plan(pibt, node, {"a": ((3, 4), (4, 4), 5.0), "b": ((5, 4), (5, 4), 0.0)})["a"] == (4, 4)


SHOP = [(-2.0, 1.5, 2.0, 0.2), (2.0, 1.5, 2.0, 0.2), (-2.0, -1.5, 2.0, 0.2), (2.0, -1.5, 2.0, 0.2)]


def wait_outside(tmp: Path, keep_clear: bool) -> tuple[float, float, float]:
    """a drives east along the shop's row y = 0.5 through its central crossing to (3.5, 0.5); b stands idle in the
    crossing's second cell (0.5, 0.5), so a has no way out of the first one. Aging off: only keep_clear_s lets a
    in. Returns when a came to rest before the crossing, when it entered it, when it reached its goal (sim s)."""
    with FleetService(FleetConfig(world=str(world(tmp, f"shop{keep_clear}", (4.8, 3.8), SHOP)), seed=0,
                                  physics_hz=20.0, control_hz=10.0)) as svc:
        tm = enable_traffic(svc, cell=1.0, urgent_s=None, highway=1.0, lane_cost=1.0, keep_clear=keep_clear,
                            keep_clear_s=3.0)
        first, second = tm.grid.node_at(-0.5, 0.5), tm.grid.node_at(0.5, 0.5)
        assert {first, second} <= tm.pibt.box or not keep_clear
        for name, (x, y) in {"a": (-3.5, 0.5), "b": (0.5, 0.5)}.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
            tm.add(name)
        truth = Truth(svc, tm)
        tm.go("a", 3.5, 0.5)
        before, rest, entered, arrived = tm.grid.node_at(-1.5, 0.5), math.inf, math.inf, math.inf
        while svc.world.time < 30.0 and math.isinf(arrived):
            svc.advance(0.1)
            if tm.a[0] == before and tm.b[0] == before and math.isinf(rest):
                rest = svc.world.time
            if tm.b[0] == first and math.isinf(entered):
                entered = svc.world.time
            if not tm.pending[0]:
                arrived = svc.world.time
        assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
        return rest, entered, arrived


def test_a_robot_kept_out_enters_after_keep_clear_s_at_rest_without_aging(tmp_path: Path) -> None:
    rest, entered, arrived = wait_outside(tmp_path, keep_clear=True)
    assert 3.0 <= entered - rest <= 4.0, (rest, entered)  # kept out 3 s at rest (the setting), then in
    assert arrived < 30.0  # and on, pushing b out of its way
    rest, entered, arrived = wait_outside(tmp_path, keep_clear=False)
    assert math.isinf(rest) and arrived < 30.0  # without the rule it drives on into the crossing without a stop


def test_keep_clear_s_is_checked(tmp_path: Path) -> None:
    with FleetService(FleetConfig(world=str(world(tmp_path, "room", (2.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc:
        for bad in (0.0, -1.0, math.inf, math.nan):
            with pytest.raises(FleetError, match="keep_clear_s"):
                TrafficManager(svc, keep_clear_s=bad)
