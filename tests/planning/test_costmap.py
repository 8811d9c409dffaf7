"""Costmap layers against closed forms: distance field, inflation, lidar marking/clearing, keep-outs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.costmap import LayeredCostmap
from planning.grid import OccupancyGrid
from planning.types import INSCRIBED, LETHAL, Costmap
from sim.types import LidarScan, Pose2D

RES = 0.05


def _single_obstacle(radius: float = 0.3, **kw) -> tuple[LayeredCostmap, tuple[float, float]]:
    grid = OccupancyGrid.empty((-2, -2, 2, 2), RES)
    r, c = grid.world_to_cell(0.01, 0.01)
    grid.data[r, c] = 100
    return LayeredCostmap(grid, robot_radius=radius, **kw), grid.cell_to_world(r, c)


def test_distance_field_and_clearance_match_euclidean_closed_form() -> None:
    cm, (ox, oy) = _single_obstacle()
    assert isinstance(cm, Costmap)
    x, y = cm.grid.cell_centres()
    assert np.allclose(cm.distance_field, np.hypot(x - ox, y - oy))
    # along an axis the clearance is the distance to the obstacle cell's edge, also between cell centres
    for d in (0.1, 0.237, 0.6, 1.31):
        assert cm.clearance(ox + d, oy) == pytest.approx(d - RES / 2, abs=1e-9)
    assert cm.clearance(ox, oy) == 0.0
    assert cm.clearance(10.0, 0.0) == 0.0  # outside the map


def test_inflation_costs_follow_nav2_exponential_decay() -> None:
    cm, (ox, oy) = _single_obstacle(radius=0.3, padding=0.0, cost_scaling_factor=3.0, inflation_radius=1.0)
    for d in (0.0, 0.1, 0.25, 0.35, 0.5, 0.95, 1.05):  # cell-centre distances, away from the 0.3 boundary
        expected = (LETHAL if d == 0 else INSCRIBED if d <= 0.3 else
                    round(252 * math.exp(-3.0 * (d - 0.3))) if d <= 1.0 else 0)
        assert cm.cost_at(ox + d, oy) == expected, d
        assert cm.is_free(ox + d, oy) == (d > 0.3)


def test_default_padding_keeps_every_free_point_a_robot_radius_away() -> None:
    cm, (ox, oy) = _single_obstacle(radius=0.3)
    pts = np.random.default_rng(1).uniform(-1.5, 1.5, (4000, 2))
    free = cm.is_free_many(pts)
    # the obstacle is the square cell around (ox, oy): distance from a point to that square
    dx = np.maximum(np.abs(pts[:, 0] - ox) - RES / 2, 0)
    dy = np.maximum(np.abs(pts[:, 1] - oy) - RES / 2, 0)
    assert (np.hypot(dx, dy)[free] >= 0.3).all()
    assert free.sum() > 0.8 * len(pts)


def _scan(ranges: np.ndarray) -> LidarScan:
    """A scan whose beam i points at −π + 2πi/n in the lidar frame."""
    n = ranges.size
    return LidarScan("r", 0.0, -math.pi, 2 * math.pi / n, 0.1, 10.0, ranges)


def test_scan_marks_returns_and_raytrace_clears_them() -> None:
    grid = OccupancyGrid.empty((-5, -5, 5, 5), RES)
    cm = LayeredCostmap(grid, robot_radius=0.2)
    ranges = np.full(8, np.inf)  # beams 45° apart, so only beam 4 passes the cells looked at
    ranges[4] = 2.0  # beam at angle 0 (robot yaw π/2 → world +y)
    pose = Pose2D(1.0, -1.0, math.pi / 2)
    cm.update_from_scan(_scan(ranges), pose)
    hit = cm.grid.world_to_cell(1.0, 1.0)
    assert cm.lethal_mask[hit] and cm.lethal_mask.sum() == 1
    assert not cm.is_free(1.0, 1.0 - 0.2)
    # the same beam now sees nothing: the mark is cleared by raytracing
    cm.update_from_scan(_scan(np.full(8, np.inf)), pose)
    assert cm.lethal_mask.sum() == 0 and cm.is_free(1.0, 1.0)
    # clearing stops at a return: a new, nearer return leaves the old mark behind it in place
    ranges[4] = 2.0
    cm.update_from_scan(_scan(ranges), pose)
    ranges[4] = 1.0
    cm.update_from_scan(_scan(ranges), pose)
    assert cm.lethal_mask[cm.grid.world_to_cell(1.0, 0.0)] and cm.lethal_mask[hit]
    # a recovery of a sensors-only robot clears only a disc about it: the marks beyond are its map
    cm.clear_dynamic((1.0, 0.2, 0.5))  # (1, 0) is 0.2 m away, (1, 1) 0.8 m
    assert not cm.lethal_mask[cm.grid.world_to_cell(1.0, 0.0)] and cm.lethal_mask[hit]
    cm.clear_dynamic()
    assert cm.lethal_mask.sum() == 0


def test_static_obstacles_are_not_cleared_by_scans() -> None:
    cm, (ox, oy) = _single_obstacle()
    cm.update_from_scan(_scan(np.full(360, np.inf)), Pose2D(-1.0, oy, 0.0))  # beam at 0 runs through it
    assert cm.lethal_mask[cm.grid.world_to_cell(ox, oy)]


def test_keepout_polygon_is_lethal_and_inflated() -> None:
    cm = LayeredCostmap(OccupancyGrid.empty((-3, -3, 3, 3), RES), robot_radius=0.25)
    version = cm.version
    cm.add_keepout([(0, 0), (1, 0), (1, 1), (0, 1)])
    assert cm.version > version
    assert not cm.is_free(0.5, 0.5) and cm.cost_at(0.5, 0.5) == LETHAL
    assert not cm.is_free(1.2, 0.5)  # within robot radius of the zone
    assert cm.is_free(1.5, 0.5)
    cm.clear_keepouts()
    assert cm.is_free(0.5, 0.5)


def test_versions_are_unique_across_costmaps() -> None:
    # planners cache per (id, version); ids are reused after garbage collection, versions never are
    a = LayeredCostmap(OccupancyGrid.empty((0, 0, 1, 1), RES), robot_radius=0.1)
    b = LayeredCostmap(OccupancyGrid.empty((0, 0, 2, 2), RES), robot_radius=0.1)
    va = a.version
    a.clear_dynamic()
    assert len({va, a.version, b.version}) == 3
