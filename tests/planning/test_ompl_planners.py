"""Each OMPL planner solves the two-room map; paths are checked with fcl, failures say why."""

from __future__ import annotations

import numpy as np
import pytest

from planning.collision import FclWorld
from planning.costmap import LayeredCostmap
from planning.global_planners import ALGORITHMS, get_planner
from planning.grid import OccupancyGrid
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D
from tests.planning.worlds import two_rooms

ROBOT = 0.3
START, GOAL = Pose2D(1.0, 1.0), Pose2D(9.0, 1.0)  # opposite rooms: the path must use the door


@pytest.fixture(scope="module")
def rooms() -> tuple[LayeredCostmap, FclWorld, float]:
    world = two_rooms()
    cm = LayeredCostmap.from_world(world, robot_radius=ROBOT, resolution=0.05)
    optimum = get_planner("theta_star").plan(START, GOAL, cm).length
    return cm, FclWorld(world), optimum


@pytest.mark.parametrize("name", sorted(ALGORITHMS))
def test_each_planner_solves_two_rooms(name: str, rooms) -> None:
    cm, fcl_world, optimum = rooms
    result = get_planner(name, time_budget_s=0.2, seed=11).plan(START, GOAL, cm)
    assert result.planner == name
    assert np.allclose(result.path[0], (1.0, 1.0)) and np.allclose(result.path[-1], (9.0, 1.0))
    assert fcl_world.path_min_distance(result.path, ROBOT, step=0.01) > 0.0
    # through the door: about the any-angle grid optimum (Theta* is not exactly optimal off the grid, so a
    # sampling planner may beat it by a hair), never near the 8 m straight line through the wall
    assert 0.99 * optimum <= result.length <= 1.3 * optimum
    assert result.info["raw_length"] >= result.length - 1e-6


def test_enclosed_goal_fails_at_once_with_the_reason() -> None:
    grid = OccupancyGrid.empty((0, 0, 6, 6), 0.05)
    x, y = grid.cell_centres()
    ring = np.abs(np.hypot(x - 4, y - 4) - 1.0) < 0.1
    grid.data[ring] = 100
    cm = LayeredCostmap(grid, robot_radius=0.2)
    with pytest.raises(FleetError) as err:
        get_planner("rrt_star", time_budget_s=5.0).plan(Pose2D(1, 1), Pose2D(4, 4), cm)
    assert err.value.code == ErrorCode.PLANNING_FAILED and "enclosed" in err.value.message
    assert err.value.hint


def test_no_path_within_budget_is_planning_failed() -> None:
    # a 2.5-cell slot through a 3 m wall: reachable, but not found in a 20 µs budget
    grid = OccupancyGrid.empty((0, 0, 8, 8), 0.05)
    x, y = grid.cell_centres()
    grid.data[(np.abs(y - 4) < 1.5) & ~(np.abs(x - 4) < 0.06)] = 100
    cm = LayeredCostmap(grid, robot_radius=0.0, padding=0.0)
    with pytest.raises(FleetError) as err:
        get_planner("rrt_connect", time_budget_s=2e-5, seed=1).plan(Pose2D(1, 1), Pose2D(7, 7), cm)
    assert err.value.code == ErrorCode.PLANNING_FAILED and "within" in err.value.message


def test_unknown_algorithm_lists_the_valid_ones() -> None:
    with pytest.raises(FleetError) as err:
        get_planner("rrt_sharp")
    assert err.value.code == ErrorCode.INVALID_ARGUMENT
    for name in ("astar", "theta_star", *ALGORITHMS):
        assert name in err.value.hint
