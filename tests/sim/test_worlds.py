"""The shipped worlds meet their specs, and the generators are deterministic and always solvable.

Reachability is checked on an occupancy grid rasterised here from the collision geometry (independent of
the planners): a disc of radius r can go from A to B iff both lie in one connected component of the cells
farther than r from every obstacle.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from sim.errors import FleetError
from sim.sdf_conventions import dock_poses, goal_pose, is_marker, spawn_pose
from sim.sdf_parser import parse_sdf
from sim.types import Box, Cylinder, Pose2D, Sphere, WorldDescription
from sim.worldgen import cluttered_arena, warehouse

WORLDS = Path(__file__).resolve().parents[2] / "configs" / "worlds"
ROBOT_RADIUS = 0.34


def footprint(world: WorldDescription, xs: np.ndarray, ys: np.ndarray, up_to: float = 0.6) -> np.ndarray:
    """Cells covered by any collision that reaches below `up_to` m (a robot's height)."""
    gx, gy = np.meshgrid(xs, ys, indexing="xy")
    occ = np.zeros(gx.shape, bool)
    for m in world.models:
        for _, c, wp in m.world_collisions():
            g = c.geometry
            if isinstance(g, Box):
                lo = wp.z - g.size[2] / 2
                cy, sy = math.cos(wp.yaw), math.sin(wp.yaw)
                lx, ly = cy * (gx - wp.x) + sy * (gy - wp.y), -sy * (gx - wp.x) + cy * (gy - wp.y)
                inside = (abs(lx) <= g.size[0] / 2) & (abs(ly) <= g.size[1] / 2)
            elif isinstance(g, Cylinder | Sphere):
                lo = wp.z - (g.length / 2 if isinstance(g, Cylinder) else g.radius)
                inside = np.hypot(gx - wp.x, gy - wp.y) <= g.radius
            else:
                continue
            if lo < up_to:
                occ |= inside
    return occ


class Reach:
    """Connected free space for a disc of radius `radius` on a `res` grid over [-half, half]²."""

    def __init__(self, world: WorldDescription, radius: float, half: float, res: float = 0.05) -> None:
        self.half, self.res = half, res
        xs = np.arange(-half, half + res / 2, res)
        free = ndimage.distance_transform_edt(~footprint(world, xs, xs)) * res > radius
        self.labels, _ = ndimage.label(free)

    def __call__(self, a: Pose2D, b: Pose2D) -> bool:
        ia, ib = (tuple(round((v + self.half) / self.res) for v in (p.y, p.x)) for p in (a, b))
        return bool(self.labels[ia] != 0 and self.labels[ia] == self.labels[ib])


def reachable(world: WorldDescription, a: Pose2D, b: Pose2D, radius: float, half: float, res: float = 0.05) -> bool:
    return Reach(world, radius, half, res)(a, b)


def box_extent(world: WorldDescription, name: str) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of a one-box model."""
    m = next(m for m in world.models if m.name == name)
    ((_, c, wp),) = m.world_collisions()
    assert isinstance(c.geometry, Box)
    sx, sy = c.geometry.size[0] / 2, c.geometry.size[1] / 2
    hx = abs(math.cos(wp.yaw)) * sx + abs(math.sin(wp.yaw)) * sy
    hy = abs(math.sin(wp.yaw)) * sx + abs(math.cos(wp.yaw)) * sy
    return (wp.x - hx, wp.y - hy, wp.x + hx, wp.y + hy)


def inner_size(world: WorldDescription) -> tuple[float, float]:
    return (box_extent(world, "wall_east")[0] - box_extent(world, "wall_west")[2],
            box_extent(world, "wall_north")[1] - box_extent(world, "wall_south")[3])


def test_robot_arena_meets_the_course_spec() -> None:
    w = parse_sdf(WORLDS / "robot_arena.world")
    assert inner_size(w) == pytest.approx((12.0, 12.0))
    obstacles = [m for m in w.obstacle_models() if not m.name.startswith(("wall_", "barrier_", "stub_"))]
    kinds = {c.geometry.kind for m in obstacles for _, c, _ in m.world_collisions()}
    assert len(obstacles) >= 5 and {"box", "cylinder", "sphere"} <= kinds
    assert len(w.lights) >= 2 and w.unsupported == ()
    assert w.ground_material is not None and Path(w.ground_material).is_file()
    texture = np.asarray(Image.open(w.ground_material), np.float64)
    assert texture.shape[0] >= 32 and texture.std() > 10.0
    for m in w.obstacle_models():
        for _, c, wp in m.world_collisions():
            assert wp.z + _top(c.geometry) >= 0.8, m.name  # the lidar at ≈ 0.57 m sees every obstacle


def _top(g: object) -> float:
    if isinstance(g, Box):
        return g.size[2] / 2
    if isinstance(g, Cylinder):
        return g.length / 2
    assert isinstance(g, Sphere)
    return g.radius


def test_robot_arena_is_a_maze_with_a_reachable_goal() -> None:
    w = parse_sdf(WORLDS / "robot_arena.world")
    start, goal = spawn_pose(w), goal_pose(w)
    assert next(m for m in w.models if m.name == "goal_marker") in [m for m in w.models if is_marker(m)]
    assert reachable(w, start, goal, ROBOT_RADIUS, 6.2)
    assert reachable(w, start, goal, 0.58, 6.2, res=0.02)  # corridors are ≥ 1.2 m wide all the way
    # ... but not in a straight line: barriers stand between start and goal
    xs = np.arange(-6.2, 6.2, 0.05)
    occ = footprint(w, xs, xs)
    ts = np.linspace(0, 1, 400)
    line = [(round((start.y + t * (goal.y - start.y) + 6.2) / 0.05),
             round((start.x + t * (goal.x - start.x) + 6.2) / 0.05)) for t in ts]
    assert any(occ[i, j] for i, j in line)


def test_warehouse_spec_aisles_docks_and_spawns() -> None:
    path = WORLDS / "warehouse.world"
    assert "<uri>model://warehouse_shelf</uri>" in path.read_text()
    w = parse_sdf(path)
    ix, iy = inner_size(w)
    assert ix >= 40.0 and iy >= 40.0
    shelves = [m for m in w.models if m.source == "model://warehouse_shelf"]
    assert len(shelves) >= 100
    # shelf rows: merge the y-extents of the racks; the gaps between merged rows are the aisles
    rows = sorted({(round(m.pose.y - 0.45, 6), round(m.pose.y + 0.45, 6)) for m in shelves})
    merged: list[list[float]] = []
    for lo, hi in rows:
        if merged and lo <= merged[-1][1] + 1e-6:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    aisles = [b[0] - a[1] for a, b in itertools.pairwise(merged)]
    assert len(aisles) >= 5 and min(aisles) >= 2.0
    docks = dock_poses(w)
    assert len(docks) >= 2 and all(is_marker(m) for m in w.models if m.name.startswith("dock_"))
    assert len(w.spawn_points) >= 3 and len(w.lights) >= 2
    reach = Reach(w, ROBOT_RADIUS, 20.5, res=0.1)
    dock = next(iter(docks.values()))
    assert all(reach(sp.pose, dock) for sp in w.spawn_points)
    # every aisle is reachable from the first spawn point
    first = w.spawn_points[0].pose
    assert all(reach(first, Pose2D(0.0, (a[1] + b[0]) / 2)) for a, b in itertools.pairwise(merged))


def test_empty_world_has_ground_sun_and_spawn_at_origin() -> None:
    w = parse_sdf(WORLDS / "empty.world")
    assert [m.name for m in w.models] == ["ground_plane"] and w.obstacle_models() == []
    assert [lt.type for lt in w.lights] == ["directional"]
    assert spawn_pose(w) == Pose2D(0.0, 0.0, 0.0)


def test_cluttered_arena_is_deterministic_by_seed() -> None:
    assert cluttered_arena(seed=7, difficulty=3) == cluttered_arena(seed=7, difficulty=3)
    assert cluttered_arena(seed=7, difficulty=3) != cluttered_arena(seed=8, difficulty=3)
    assert warehouse() == warehouse()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cluttered_arena_difficulty_raises_density_and_keeps_a_corridor(seed: int) -> None:
    counts = []
    for difficulty in range(1, 6):
        w = cluttered_arena(seed=seed, difficulty=difficulty)
        counts.append(len(w.obstacle_models()) - 4)  # minus the four walls
        assert inner_size(w) == pytest.approx((10.0, 10.0))
        assert reachable(w, spawn_pose(w), goal_pose(w), 0.75, 5.2)  # the 1.6 m corridor, with margin
        for m in w.obstacle_models():
            for _, c, wp in m.world_collisions():
                assert wp.z + _top(c.geometry) >= 0.8
    assert counts == sorted(counts) and counts[-1] >= 3 * counts[0]


def test_generators_reject_bad_arguments() -> None:
    with pytest.raises(FleetError, match="difficulty"):
        cluttered_arena(seed=0, difficulty=6)
    with pytest.raises(FleetError, match="aisle"):
        warehouse(aisle_width=1.5)
