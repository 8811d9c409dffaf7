"""Helper 17e: the Embree caster's per-cast shortcuts return exactly what the longer way gives.

- scene.cast settles misses, flat hits and front-face hits in one pass over whole arrays; checked bit for bit
  against sending every hit through the pass-by-pass continuation (the path before), on boxes, cylinders and
  spheres with rays that start inside boxes (back faces) and graze the curved shapes' proxies.
- The caster's kept work arrays (sim/raycast_scratch.py): a cast after casts of other sizes equals a fresh
  caster's, the results handed out are not overwritten by the next cast, and a bigger batch reallocates.
- The exact curved-shape tests skip the caps for rays that cannot enter one: checked against a per-ray closed
  form, and a ray's t does not depend on the batch it is in.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import Pose2D, World
from sim import raycast_exact as exact
from sim import raycast_scene as scene
from sim.raycast_embree import EmbreeCaster
from sim.raycast_layout import RayLayout
from sim.raycast_scratch import Scratch
from sim.raycast_shapes import BOX, CYLINDER, SPHERE, Shape, box_mesh, prism_proxy, sphere_proxy
from tests.sim.lidar_fleet import lidar_fleet


def _frame(x: float, y: float, z: float, yaw: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    m[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    m[:3, 3] = x, y, z
    return m


def _geometry() -> scene.Geometry:
    """Two boxes, two cylinders and a sphere, as one static body each."""
    parts = []
    for uid, (kind, size, frame) in enumerate([(BOX, (0.5, 0.3, 0.4), _frame(1.0, 0.0, 0.4, 0.3)),
                                               (BOX, (0.2, 1.5, 0.5), _frame(-2.0, 0.5, 0.5)),
                                               (CYLINDER, (0.3, 0.5), _frame(0.0, 2.0, 0.5)),
                                               (CYLINDER, (0.1, 0.3), _frame(2.0, 2.0, 0.3)),
                                               (SPHERE, (0.4, 0.0), _frame(-1.0, -2.0, 0.4))]):
        if kind == BOX:
            verts, faces = box_mesh(np.asarray(size))
            radius, half = 0.0, 0.0
        elif kind == CYLINDER:
            radius, half = size
            verts, faces = prism_proxy(radius, half)
        else:
            radius, half = size[0], 0.0
            verts, faces = sphere_proxy(radius)
        shape = Shape(uid, -1, kind, radius, half, np.eye(4), verts, faces)
        parts.append(([shape], frame[None], np.array([uid])))
    g = scene.commit([scene.build(parts)])
    assert g is not None
    return g


def _pass_by_pass(g: scene.Geometry, o: np.ndarray, d: np.ndarray, limit: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Every first-pass hit through scene._continue (what scene.cast did before the one-pass shortcut)."""
    d32 = d.astype(np.float32)
    prim, t32, ng = scene._run(g, o.astype(np.float32), d32, limit.astype(np.float32))
    t_hit, uid = np.full(len(o), np.inf), np.full(len(o), -1, np.int64)
    active = np.flatnonzero(prim >= 0)
    scene._continue(g, o, d, d32, limit, active, prim[active], t32[active].astype(np.float64),
                    ng.take(active, axis=0), t_hit, uid)
    return t_hit, uid


def test_one_pass_shortcut_equals_pass_by_pass() -> None:
    g = _geometry()
    rng = np.random.default_rng(11)
    n = 6000
    o = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(0.05, 1.2, n)])
    o[:300] = np.array([1.0, 0.0, 0.4]) + rng.uniform(-0.2, 0.2, (300, 3))  # inside the first box: its back faces
    aim = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(0.0, 1.2, n)])
    aim[::2, 2] = o[::2, 2]  # half level, like a lidar's
    d = (aim - o) * 3.0
    limit = np.where(rng.random(n) < 0.3, rng.uniform(0.05, 1.0, n), 1.0)
    t, uid = scene.cast(g, o, d, limit, Scratch())
    ref_t, ref_uid = _pass_by_pass(g, o, d, limit)
    assert np.array_equal(t, ref_t) and np.array_equal(uid, ref_uid)
    # the case mix is really there: hits on every body, curved refinements, rays that went on
    assert set(np.unique(uid).tolist()) == {-1, 0, 1, 2, 3, 4}
    inside_hits = uid[:300]
    assert (inside_hits != 0).all()  # a ray starting inside a box does not see it


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    return lidar_fleet(tmp_path_factory.mktemp("overhead"), "overhead", world_seed=3, heading_seed=4)


def _lidar_rays(world: World) -> list[tuple[np.ndarray, np.ndarray, RayLayout | None]]:
    seen: list[tuple[np.ndarray, np.ndarray, RayLayout | None]] = []
    cast = world.cast_rays

    def record(o: np.ndarray, e: np.ndarray, layout: RayLayout | None = None) -> tuple[np.ndarray, np.ndarray]:
        seen.append((o.copy(), e.copy(), layout))
        return cast(o, e, layout)

    world.cast_rays = record  # type: ignore[method-assign,assignment]
    try:
        world.step(2)
    finally:
        del world.cast_rays
    return seen


def test_kept_work_arrays_equal_a_fresh_caster(world: World) -> None:
    world.set_raycaster("embree")
    o, e, layout = _lidar_rays(world)[-1]
    caster = world.rays.embree
    caster.fans = None  # cast every time
    rng = np.random.default_rng(5)
    bare_o = np.column_stack([rng.uniform(-4, 4, 500), rng.uniform(-3, 3, 500), rng.uniform(0.1, 0.9, 500)])
    bare_e = bare_o + rng.normal(size=(500, 3)) * [6.0, 6.0, 0.3]
    batches = [(o, e, layout), (o[:720], e[:720], None), (bare_o, bare_e, None),
               (np.vstack([o, bare_o]), np.vstack([e, bare_e]), None), (o, e, layout)]
    kept = []
    most = 0  # the biggest batch so far: the kept arrays hold that many rows
    for bo, be, bl in batches:
        before = caster._scratch.allocations
        got = caster.cast(bo, be, bl)
        fresh = EmbreeCaster(world)
        fresh.fans = None
        ref = fresh.cast(bo, be, bl)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
        assert (got[1] >= 0).mean() > 0.2
        assert (caster._scratch.allocations > before) == (len(bo) > most)  # only a bigger batch reallocates
        most = max(most, len(bo))
        kept.append((got, tuple(a.copy() for a in got)))
    for got, copy in kept:  # what a cast handed out stays as it was
        assert np.array_equal(got[0], copy[0]) and np.array_equal(got[1], copy[1])


def _cylinder_ref(o: np.ndarray, d: np.ndarray, r: float, h: float) -> float:
    """Entry t of one ray into the solid cylinder x² + y² ≤ r², |z| ≤ h, by candidates: inf if it starts
    inside or misses."""
    if o[0] ** 2 + o[1] ** 2 <= r * r and abs(o[2]) <= h:
        return math.inf
    best = math.inf
    a = d[0] ** 2 + d[1] ** 2
    if a > 0:
        b, c = 2 * (o[0] * d[0] + o[1] * d[1]), o[0] ** 2 + o[1] ** 2 - r * r
        disc = b * b - 4 * a * c
        if disc >= 0 and c > 0:
            t = (-b - math.sqrt(disc)) / (2 * a)
            if t >= 0 and abs(o[2] + t * d[2]) <= h:
                best = t
    if d[2] != 0 and abs(o[2]) > h:
        t = (math.copysign(h, o[2]) - o[2]) / d[2]
        x, y = o[0] + t * d[0], o[1] + t * d[1]
        if t >= 0 and x * x + y * y <= r * r:
            best = min(best, t)
    return best


def test_cylinder_caps_and_batch_independence() -> None:
    rng = np.random.default_rng(8)
    n = 3000
    o = rng.uniform(-1.5, 1.5, (n, 3))
    d = rng.uniform(-0.9, 0.9, (n, 3)) - o
    d[: n // 3, 2] = 0.0  # level rays: no cap test at all
    o[n // 3: n // 2, :2] *= 0.1  # above and below the caps, looking at them
    d[n // 3: n // 2, :2] *= 0.1
    r, h = 0.6, 0.4
    t = exact.cylinder(o, d, r, h)
    ref = np.array([_cylinder_ref(o[i], d[i], r, h) for i in range(n)])
    fin = np.isfinite(ref)
    assert np.array_equal(np.isfinite(t), fin) and fin.sum() > n // 4
    assert np.allclose(t[fin], ref[fin], rtol=0, atol=1e-12)
    caps = fin & (np.abs(o[:, 2] + np.where(fin, ref, 0.0) * d[:, 2]) >= h - 1e-9) & (np.abs(o[:, 2]) > h)
    assert caps.sum() > 50  # rays really entered through a cap
    sub = rng.permutation(n)[: n // 5]  # a ray's t is the same in any batch, with radii per ray or shared
    assert np.array_equal(exact.cylinder(o[sub], d[sub], np.full(sub.size, r), np.full(sub.size, h)), t[sub])
    assert np.array_equal(exact.capsule(o[sub], d[sub], r, h), exact.capsule(o, d, r, h)[sub])


def test_split_over_threads_equals_one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """The same rays cast in chunks over the thread pool (tfar written into views of one array) and on one
    thread give the same hits."""
    g = _geometry()
    rng = np.random.default_rng(2)
    n = 5000
    o = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(0.05, 1.2, n)])
    d = np.column_stack([rng.normal(size=(n, 2)) * 4.0, np.zeros(n)])
    monkeypatch.setattr(scene, "CHUNK_MIN", 10**9)
    one = scene.cast(g, o, d, np.ones(n))
    one = (one[0].copy(), one[1].copy())
    monkeypatch.setattr(scene, "CHUNK_MIN", 1000)
    monkeypatch.setattr(scene, "THREADS", 3)
    monkeypatch.setattr(scene, "_split", scene.SplitPolicy())
    split = scene.cast(g, o, d, np.ones(n))
    assert scene._split.split >= 1  # really split (the first pass, at least)
    assert np.array_equal(one[0], split[0]) and np.array_equal(one[1], split[1])


def test_split_policy_stays_on_one_thread_after_a_split_that_did_not_pay() -> None:
    p = scene.SplitPolicy()
    assert p.use_split()
    p.record(own_s=1.0e-3, total_s=1.1e-3, k=2)  # ~half of one thread's 2 ms: keep splitting
    assert p.use_split()
    p.record(own_s=1.0e-3, total_s=1.9e-3, k=2)  # the worker waited for a core: as slow as one thread
    assert [p.use_split() for _ in range(scene.PROBE_EVERY)] == [False] * scene.PROBE_EVERY
    assert p.use_split()  # then tried again
    assert (p.split, p.single) == (3, scene.PROBE_EVERY)


def test_cached_moving_bodies_follow_spawns_and_motion(world: World) -> None:
    """With a dynamic robot the engine steps and every body is posed from PyBullet (_moving, its link list
    cached): after the bodies move and after another robot is spawned, casts equal a fresh caster's. Runs
    last: it changes the shared world."""
    world.set_raycaster("embree")
    world.spawn_robot("dyn", Pose2D(0.0, 0.0, 0.5), fidelity="dynamic")
    world.set_cmd_vel("dyn", 0.4, 0.3)
    caster = world.rays.embree
    caster.fans = None
    for k in range(3):
        world.step(3)
        if k == 1:
            world.spawn_robot("dyn2", Pose2D(1.0, 1.5, -1.0), fidelity="dynamic")
        o, e, layout = _lidar_rays(world)[-1]
        got = caster.cast(o, e, layout)
        fresh = EmbreeCaster(world)
        fresh.fans = None
        ref = fresh.cast(o, e, layout)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
        # every robot's links, posed from PyBullet
        assert {u for u, _ in caster._moving_links} == set(world.table.body.tolist())
