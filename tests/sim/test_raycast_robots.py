"""Robots in the Embree caster without a rebuild: upright (kinematic) robots are intersected in closed form at
their current poses; ranges equal PyBullet's rayTestBatch within 1 mm after the robots move."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from sim import Pose2D, World
from sim import raycast_robots as rr
from sim.raycast_shapes import box_mesh
from sim.sdf_primitives import box, cylinder, ground_plane
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    tmp = tmp_path_factory.mktemp("raycast_robots")
    models = [ground_plane(size=40), box("wall", (0.3, 8.0, 1.0), 5.0, 0.0), cylinder("post", 0.3, 1.0, -3.0, 2.0)]
    path = tmp / "scene.world"
    save_sdf(WorldDescription(name="robots", models=tuple(models)), str(path))
    w = World.from_sdf(Path(path), physics_hz=20.0, fidelity="kinematic")
    rng = np.random.default_rng(7)
    for k in range(12):  # a 4 × 3 grid, 1.5 m apart
        w.spawn_robot(f"r{k}", Pose2D(-2.5 + 1.5 * (k % 4), -1.5 + 1.5 * (k // 4), float(rng.uniform(-3, 3))))
    return w


def _compare(w: World, origins: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    w.set_raycaster("pybullet")
    ref_f, ref_u = w.cast_rays(origins, ends)
    w.set_raycaster("embree")
    f, u = w.cast_rays(origins, ends)
    return ref_u, u, np.abs(ref_f - f) * np.linalg.norm(ends - origins, axis=1)


def _robot_rays(w: World, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays aimed at robots from 1–3 m away, at every height of their bodies (chassis, mast, lidar head)."""
    rng = np.random.default_rng(seed)
    f = w.table.f
    k = rng.integers(0, len(w.table), n)
    ang = rng.uniform(-math.pi, math.pi, n)
    dist = rng.uniform(1.0, 3.0, n)
    z = rng.uniform(0.03, 0.6, n)
    o = np.column_stack([f["x"][k] + dist * np.cos(ang), f["y"][k] + dist * np.sin(ang), z])
    aim = np.column_stack([f["x"][k] + rng.uniform(-0.3, 0.3, n), f["y"][k] + rng.uniform(-0.3, 0.3, n),
                           z + rng.uniform(-0.1, 0.1, n)])
    return o, o + 4.0 * (aim - o) / np.linalg.norm(aim - o, axis=1)[:, None]


def test_robots_match_rayTestBatch_after_moving_without_rebuild(world: World) -> None:
    for k in range(0, 12, 2):
        world.set_cmd_vel(f"r{k}", 0.4, 0.8)
    world.set_robot_pose("r1", Pose2D(0.3, 2.8, 1.0))
    world.step(10)
    for seed in (1, 2):  # before and after another move
        o, e = _robot_rays(world, 6000, seed)
        ref_u, u, err = _compare(world, o, e)
        robot_uids = {b.uid for b in world.bodies.values()}
        on_robot = np.isin(ref_u, list(robot_uids))
        assert on_robot.mean() > 0.3  # the mast and lidar head are thin: most rays at their height miss
        assert np.mean(ref_u == u) > 0.995  # the same body (or miss), but for edge-grazing rays
        same = (u >= 0) & (u == ref_u)
        flat = same & on_robot & (o[:, 2] < 0.24)  # the chassis box: flat faces
        assert flat.sum() > 500
        assert np.mean(err[flat] < 1e-3) > 0.995
        curved = same & on_robot & (o[:, 2] > 0.3)  # mast and lidar head: Bullet's cylinder is approximate
        assert curved.sum() > 200 and np.median(err[curved]) < 1e-3
        world.step(7)
    # The robots were cast in closed form: nothing was built for them.
    assert world.rays.embree._dynamic_scene((0.0, 1.0)) == []


def test_lidar_scans_see_moved_neighbours_like_rayTestBatch(world: World) -> None:
    world.set_cmd_vel("r5", 0.5, -1.0)
    world.step(4)
    snap = world.snapshot()
    world.set_raycaster("pybullet")
    world.step(2)
    ref = {n: world.latest_scan(n) for n in world.robot_names()}
    world.restore(snap)
    world.set_raycaster("embree")
    world.step(2)
    robot_uids = [b.uid for b in world.bodies.values()]
    seen = 0
    for name, r in ref.items():
        ours = world.latest_scan(name)
        assert r is not None and ours is not None and r.stamp == ours.stamp
        assert r.hit_bodies is not None and ours.hit_bodies is not None
        assert np.mean(np.isfinite(r.ranges) == np.isfinite(ours.ranges)) > 0.98
        both = np.isfinite(r.ranges) & np.isfinite(ours.ranges) & (r.hit_bodies == ours.hit_bodies)
        seen += int(np.isin(ours.hit_bodies[both], robot_uids).sum())
        assert np.median(np.abs(r.ranges[both] - ours.ranges[both])) < 1e-3
    assert seen > 20  # lidars do see the neighbours' lidar heads


def test_box_slab_and_hull_planes_equal_closed_form() -> None:
    """A box as a slab test and as its convex hull's planes give the same entry distance as a direct
    computation; rays starting inside, parallel outside, and pointing away miss."""
    half = np.array([0.5, 0.3, 0.2])
    verts, _ = box_mesh(half)
    planes = ConvexHull(verts).equations
    rng = np.random.default_rng(0)
    n = 4000
    o = rng.uniform(-2, 2, (n, 3))
    aim = rng.uniform(-0.6, 0.6, (n, 3))
    d = aim - o
    t_box, t_hull = rr._box(o, d, half), rr._convex(o, d, planes)
    fin = np.isfinite(t_box)
    assert np.array_equal(fin, np.isfinite(t_hull)) and fin.sum() > n // 4
    assert np.allclose(t_box[fin], t_hull[fin], atol=1e-12)
    p = o[fin] + t_box[fin, None] * d[fin]  # the entry point lies on the surface
    assert np.allclose(np.max(np.abs(p) / half, axis=1), 1.0, atol=1e-9)
    inside = np.all(np.abs(o) < half, axis=1)
    assert not fin[inside].any()
    # axis-parallel rays: one inside the slab (hits at x = -0.5), one outside it (misses)
    o2 = np.array([[-2.0, 0.0, 0.0], [-2.0, 0.5, 0.0], [-2.0, 0.0, 0.0]])
    d2 = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    assert np.allclose(rr._box(o2, d2, half), [1.5, np.inf, np.inf])
    assert np.allclose(rr._convex(o2, d2, planes), [1.5, np.inf, np.inf])
