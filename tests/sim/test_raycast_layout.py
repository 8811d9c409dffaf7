"""Issue 17c: the lidar's ray layout handed to the Embree caster, and movable models without a rebuild.

The same lidar rays cast by Embree with the layout, by Embree without it (bare rays: groups recovered from
the rays) and by PyBullet's rayTestBatch agree; movable models (box, cylinder, sphere, convex mesh) moved and
tilted between casts are intersected at their new poses with no Embree scene built for them and the static
BVH kept."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sim import Pose2D, World
from sim.errors import FleetError
from sim.raycast_layout import RayLayout
from sim.sdf_primitives import box, cylinder, ground_plane, sphere
from sim.sdf_writer import save_sdf
from sim.types import Collision, Link, Mesh, ModelDescription, Pose3D, Visual, WorldDescription
from tests.sim.lidar_fleet import lidar_fleet

# A cube with a dented top (concave as a trimesh); a movable body collides with its convex hull.
OBJ = """v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nv 0.5 0.5 0.4
f 1 3 2\nf 1 4 3\nf 5 6 9\nf 6 7 9\nf 7 8 9\nf 8 5 9\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7
f 4 1 5\nf 4 5 8
"""
MOVABLE = ("mbox", "mcyl", "mball", "mcrate")


def _movable(m: ModelDescription) -> ModelDescription:
    link = replace(m.links[0], mass=2.0, inertia=(0.1, 0, 0, 0.1, 0, 0.1))
    return replace(m, static=False, links=(link,))


def _record(w: World) -> list[tuple[np.ndarray, np.ndarray, RayLayout | None]]:
    """Every cast the World makes from now on: (origins, ends, layout)."""
    seen: list[tuple[np.ndarray, np.ndarray, RayLayout | None]] = []
    cast = w.rays.cast

    def record(origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        seen.append((origins.copy(), ends.copy(), layout))
        return cast(origins, ends, layout)

    w.rays.cast = record  # type: ignore[method-assign]
    return seen


def _three_ways(w: World, o: np.ndarray, e: np.ndarray, layout: RayLayout | None
                ) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """(fraction, uid) by Embree with the layout, Embree on the bare rays, and rayTestBatch."""
    w.set_raycaster("embree")
    with_layout = w.rays.embree.cast(o, e, layout)
    bare = w.rays.embree.cast(o, e)
    w.set_raycaster("pybullet")
    ref = w.cast_rays(o, e, layout)
    w.set_raycaster("embree")
    return with_layout, bare, ref


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> World:
    """The shared lidar fleet (tests/sim/lidar_fleet.py)."""
    return lidar_fleet(tmp_path_factory.mktemp("layout"), "layout", world_seed=3, heading_seed=11)


def test_lidar_layout_equals_bare_rays_and_rayTestBatch(fleet: World) -> None:
    seen = _record(fleet)
    fleet.step(3)  # every lidar fires each 10 Hz step; the robots move between casts
    fleet.rays.__dict__.pop("cast")
    assert len(seen) == 3
    robot_uids = [b.uid for b in fleet.bodies.values()]
    for o, e, layout in seen:
        assert layout is not None and layout.start.size == 10 and int(layout.count.sum()) == len(o)
        lo, le = layout.rays()  # the layout describes exactly these rays
        assert np.allclose(lo, o, rtol=0, atol=1e-9) and np.allclose(le, e, rtol=0, atol=1e-9)
        (fl, ul), (fb, ub), (fp, up) = _three_ways(fleet, o, e, layout)
        length = np.linalg.norm(e - o, axis=1)
        # With and without the layout: the same pairs survive the exact test, so the same hits and ranges.
        assert np.array_equal(ul, ub)
        assert np.allclose(fl * length, fb * length, rtol=0, atol=1e-9)
        # Against rayTestBatch: the same body, and the same range within 1 mm on flat faces.
        assert np.mean(ul == up) > 0.995
        same = (ul >= 0) & (ul == up)
        err = np.abs(fl - fp) * length
        on_robot = np.isin(ul, robot_uids)
        assert on_robot[same].sum() > 20  # the neighbours' lidar heads
        flat = same & ~on_robot & (ul != fleet.models.records["post"].uids[0])
        assert flat.sum() > 1000 and np.mean(err[flat] < 1e-3) > 0.995
        assert np.median(err[same & on_robot]) < 1e-3  # lidar heads are cylinders: Bullet's is approximate


def test_a_layout_that_does_not_describe_the_rays_is_refused(fleet: World) -> None:
    seen = _record(fleet)
    fleet.step()
    fleet.rays.__dict__.pop("cast")
    o, e, layout = seen[-1]
    assert layout is not None
    fleet.set_raycaster("embree")
    turned = replace(layout, heading=layout.heading + np.where(np.arange(layout.start.size) == 4, 0.1, 0.0))
    with pytest.raises(FleetError, match="ray layout: ray 1440 is not where fan 4 puts it"):
        fleet.cast_rays(o, e, turned)
    short = replace(layout, count=layout.count - np.eye(layout.start.size, dtype=np.int64)[-1])
    with pytest.raises(FleetError, match="do not cover"):
        fleet.cast_rays(o, e, short)


@pytest.fixture(scope="module")
def yard(tmp_path_factory: pytest.TempPathFactory) -> World:
    tmp = tmp_path_factory.mktemp("movable")
    obj = tmp / "dent.obj"
    obj.write_text(OBJ, encoding="utf-8")
    g = Mesh(str(obj), str(obj), (0.6, 0.6, 0.6))
    crate = ModelDescription("mcrate", Pose3D(-2.0, -1.5, 0.01), False,
                             (Link("link", mass=3.0, inertia=(0.2, 0, 0, 0.2, 0, 0.2),
                                   collisions=(Collision("c", g),), visuals=(Visual("v", g),)),))
    models = [ground_plane(size=40), box("wall", (0.3, 8.0, 1.0), 5.0, 0.0),
              _movable(box("mbox", (0.6, 0.4, 0.5), 1.5, 1.5, 0.3)), _movable(cylinder("mcyl", 0.3, 0.8, -1.5, 1.5)),
              _movable(sphere("mball", 0.35, 1.5, -1.5)), crate]
    path = tmp / "yard.world"
    save_sdf(WorldDescription(name="yard", models=tuple(models)), str(path))
    w = World.from_sdf(Path(path), physics_hz=50.0, fidelity="kinematic", seed=1)
    for k in range(4):
        w.spawn_robot(f"k{k}", Pose2D(-3.5 + 2.3 * k, 3.2, 0.4 * k))
    return w


def _aimed(w: World, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Rays aimed at the movable models from 1–3 m away, at heights across their bodies."""
    rng = np.random.default_rng(seed)
    centres = np.array([w.get_model_state(m).pose.position for m in MOVABLE])
    k = rng.integers(0, len(centres), n)
    ang = rng.uniform(-math.pi, math.pi, n)
    dist = rng.uniform(1.0, 3.0, n)
    c = centres[k]
    o = np.column_stack([c[:, 0] + dist * np.cos(ang), c[:, 1] + dist * np.sin(ang), rng.uniform(0.05, 0.9, n)])
    aim = c + rng.uniform(-0.4, 0.4, (n, 3))
    return o, o + 4.0 * (aim - o) / np.linalg.norm(aim - o, axis=1)[:, None]


def test_moved_models_match_rayTestBatch_without_a_rebuild(yard: World) -> None:
    w = yard
    uid = {m: w.models.records[m].uids[0] for m in MOVABLE}
    w.step(5)
    w.set_raycaster("embree")
    w.cast_rays(*_aimed(w, 10, 0))
    static = w.rays.embree._static_scene()
    moves = [{"mbox": Pose3D(-0.5, 0.0, 0.9, 0.4, 0.3, 1.0), "mcyl": Pose3D(2.0, -0.5, 0.6, 1.2, 0.0, 0.5),
              "mball": Pose3D(0.5, 1.8, 0.6), "mcrate": Pose3D(-2.5, 0.5, 0.3, 0.0, 0.6, 2.0)},
             {"mbox": Pose3D(2.5, 2.0, 0.25, 0.0, 0.0, -0.7), "mcyl": Pose3D(-1.0, -2.0, 0.4),
              "mball": Pose3D(-2.5, 2.0, 0.35), "mcrate": Pose3D(1.0, -2.5, 0.05, 0.0, 0.0, 0.9)}]
    for seed, move in enumerate(moves):
        for name, pose in move.items():  # tilted in the air (first round), then back on the floor
            w.set_model_state(name, pose=pose)
        if seed:
            w.step(3)  # and moved by physics
        o, e = _aimed(w, 6000, seed + 1)
        (f, u), _, (fp, up) = _three_ways(w, o, e, None)
        w.rays.embree.closed_form = False  # the path before: the moving bodies built as triangles per cast
        fr, ur = w.cast_rays(o, e)
        w.rays.embree.closed_form = True
        length = np.linalg.norm(e - o, axis=1)
        err = np.abs(f - fp) * length
        assert np.mean(u == up) > 0.995
        assert np.mean(u == ur) > 0.999  # the same geometry as the triangles (float32 in Embree: edge rays)
        both = (u >= 0) & (u == ur)
        assert np.mean(np.abs(f - fr)[both] * length[both] < 1e-4) > 0.999
        for name in MOVABLE:
            m = (u == uid[name]) & (up == uid[name])
            assert m.sum() > 400, name
            if name == "mbox":  # flat faces: exact but for rays grazing a face or an edge (Bullet's margin)
                assert np.mean(err[m] < 1e-3) > 0.99 and np.median(err[m]) < 1e-6, name
            else:  # Bullet's curved ray test is approximate, and its hull carries a ~1 mm margin
                assert np.median(err[m]) < 1.5e-3, name
        # The ball against the closed form (the sphere at its pose now).
        centre = np.array(w.get_model_state("mball").pose.position)
        d = e - o
        oc = o - centre
        a, b, c = (d * d).sum(1), (oc * d).sum(1), (oc * oc).sum(1) - 0.35**2
        ball = u == uid["mball"]
        t = (-b[ball] - np.sqrt(b[ball] ** 2 - a[ball] * c[ball])) / a[ball]
        assert np.max(np.abs(t - f[ball]) * length[ball]) < 1e-9
        # Nothing was built for the moving bodies and the static BVH is the one from before the moves.
        assert w.rays.embree._dynamic_scene((0.0, 1.5)) == []
        assert w.rays.embree._static_scene() is static


def test_lidar_scans_see_moved_models_like_rayTestBatch(yard: World) -> None:
    w = yard
    w.set_model_state("mbox", pose=Pose3D(-2.0, 3.2, 0.25, 0.0, 0.0, 0.3))  # between two robots
    seen = _record(w)
    w.step(5)  # one 10 Hz lidar sweep of every robot within these steps
    w.rays.__dict__.pop("cast")
    hits = 0
    for o, e, layout in seen:
        assert layout is not None
        (fl, ul), (fb, ub), (fp, up) = _three_ways(w, o, e, layout)
        assert np.array_equal(ul, ub) and np.allclose(fl, fb, rtol=0, atol=1e-12)
        assert np.mean(ul == up) > 0.99
        same = (ul >= 0) & (ul == up)
        assert np.median((np.abs(fl - fp) * np.linalg.norm(e - o, axis=1))[same]) < 1e-3
        hits += int(np.isin(ul[same], [w.models.records[m].uids[0] for m in MOVABLE]).sum())
    assert len(seen) >= 1 and hits > 20


def test_moving_a_static_model_or_restoring_a_snapshot_rebuilds_the_static_scene(yard: World) -> None:
    w = yard
    w.set_raycaster("embree")
    wall = w.models.records["wall"].uids[0]
    o, e = np.array([[3.0, 0.0, 0.5]]), np.array([[7.0, 0.0, 0.5]])  # along +x into the wall at x = 5 − 0.15
    assert w.cast_rays(o, e)[1][0] == wall
    static, boxes = w.rays.embree._static_scene(), w.models.static_obstacle_aabbs()
    snap = w.snapshot()
    w.set_model_state("wall", pose=Pose3D(4.0, 0.0, 0.5))  # 1 m closer: the hit moves with it
    f, u = w.cast_rays(o, e)
    assert u[0] == wall and abs(f[0] * 4.0 - 0.85) < 1e-3
    assert w.rays.embree._static_scene() is not static
    assert w.models.static_obstacle_aabbs()[1] is not boxes[1]
    w.restore(snap)  # the wall is back at x = 5 in PyBullet: the static caches must follow
    f, u = w.cast_rays(o, e)
    fp, up = w.cast_rays_pybullet(o, e)
    assert u[0] == up[0] == wall and abs(f[0] - fp[0]) * 4.0 < 1e-3
