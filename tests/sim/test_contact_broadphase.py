"""The kinematic contact broadphase (sweep + oriented boxes) finds exactly what brute force finds.

Ground truth: getClosestPoints on every robot against every other body (sim/contact_query.py may only skip
pairs that cannot penetrate). Scenes are dense and random: robots overlapping each other at random headings,
rotated boxes, cylinders and walls, and a robot whose mast sticks out of its footprint circle.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb
import pytest

import sim.contact_query as cq
from sim import Pose2D, World
from sim.contact_query import PENETRATION, boxes_overlap, robot_penetrations
from sim.types import Box, Collision, Cylinder, Link, ModelDescription, Pose3D, Visual


def add_static(w: World, name: str, geom: Box | Cylinder, x: float, y: float, yaw: float = 0.0, *,
               roll: float = 0.0, static: bool = True) -> None:
    link = Link("link", mass=0.0 if static else 5.0, inertia=(0.5, 0, 0, 0.5, 0, 0.5),
                collisions=(Collision("c", geom),), visuals=(Visual("v", geom),))
    h = geom.size[2] if isinstance(geom, Box) else geom.length
    w.models.add_model(ModelDescription(name, Pose3D(x, y, h / 2, roll, 0, yaw), static, (link,)))
    w._sync_labels()


def brute_force(w: World, rows: np.ndarray) -> dict[frozenset[int], float]:
    """{pair: distance} of every pair involving a robot in `rows` deeper than the tolerance, all pairs tried."""
    robots = [int(u) for u in w.table.body[rows]]
    ground = w.models.ground_uids()
    every = [pb.getBodyUniqueId(k, physicsClientId=w.client) for k in range(pb.getNumBodies(physicsClientId=w.client))]
    out = {}
    for a in robots:
        for b in every:
            if b == a or b in ground:
                continue
            d = min((c[8] for c in pb.getClosestPoints(a, b, 0.0, physicsClientId=w.client)), default=1.0)
            if d < PENETRATION:
                out[frozenset((a, b))] = d
    return out


def dense_world(seed: int) -> World:
    w = World(physics_hz=10, seed=seed)
    rng = np.random.default_rng(seed)
    base = w.default_spec()
    spec = base.model_copy(update={"sensors": base.sensors.model_copy(
        update={"lidar": base.sensors.lidar.model_copy(update={"enabled": False})})})
    # the mast 0.6 m ahead: outside the footprint circle (0.34 m), inside the measured collision box
    long_mast = spec.model_copy(update={"mast": spec.mast.model_copy(update={"x_offset": 0.6})})
    for k in range(70):
        s = long_mast if k % 7 == 0 else spec
        x, y, yaw = rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-math.pi, math.pi)
        w.spawn_robot(f"r{k}", Pose2D(x, y, yaw), s, check_collision=False)
    for k in range(12):
        x, y = rng.uniform(-4.5, 4.5, 2)
        if k % 2:
            add_static(w, f"box{k}", Box((*rng.uniform(0.2, 1.5, 2), 1.0)), x, y, rng.uniform(-math.pi, math.pi))
        else:
            add_static(w, f"cyl{k}", Cylinder(rng.uniform(0.1, 0.6), 1.0), x, y)
    add_static(w, "wall_n", Box((10.0, 0.2, 1.0)), 0.0, 4.2)
    add_static(w, "wall_e", Box((0.2, 10.0, 1.0)), 4.2, 0.0)
    add_static(w, "beam", Box((3.0, 0.3, 0.2)), -2.0, -2.0, 0.5)  # low and long, at a slant
    add_static(w, "leaning", Box((1.0, 0.4, 1.0)), 1.5, -1.0, 0.3, roll=0.4)  # tilted: its AABB stands in
    add_static(w, "cart", Box((0.8, 0.6, 0.5)), -1.0, 2.0, 0.7, static=False)  # a moving model
    add_static(w, "drum", Cylinder(0.4, 0.9), 2.0, 2.5, static=False)
    return w


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_broadphase_finds_exactly_the_brute_force_penetrations(seed: int):
    with dense_world(seed) as w:
        rng = np.random.default_rng(seed + 10)
        for rows in (np.arange(len(w.table)), np.sort(rng.choice(len(w.table), 25, replace=False))):
            truth = brute_force(w, rows)
            fast = {frozenset((a, b)): d for a, b, _, d in robot_penetrations(w, rows)}
            assert len(truth) > 20  # a dense scene: the comparison is not vacuous
            if rows.size == len(w.table):  # the moving model and the tilted box (its AABB stands in) take part
                assert {"cart", "leaning"} <= {w.body_label(u)[0] for pair in truth for u in pair}
            assert fast.keys() == truth.keys()
            for pair, d in truth.items():
                assert fast[pair] == pytest.approx(d, abs=1e-6)  # a/b swapped: GJK rounding
            # each candidate once, the rows' robot first; and the boxes prune: fewer queries than brute force
            pairs = cq.candidate_pairs(w, rows)
            assert len(set(pairs)) == len(pairs) and {w.table.row_of_uid[a] for a, _ in pairs} <= set(rows.tolist())
            assert len(pairs) < 3 * len(truth)


def test_a_mast_outside_the_footprint_circle_still_collides():
    """The broadphase reads the measured collision box, not the footprint circle: a mast 0.6 m ahead of a
    robot whose circle is 0.34 m finds the crate it pokes into, and the robot is refused there."""
    with World(physics_hz=10) as w:
        spec = w.default_spec()
        spec = spec.model_copy(update={"mast": spec.mast.model_copy(update={"x_offset": 0.6})})
        add_static(w, "crate", Box((0.2, 0.2, 1.0)), 0.73, 0.0)  # near face at x = 0.63; housing reaches 0.65
        w.spawn_robot("r", Pose2D(0.0, 0.0, 0.0), spec, check_collision=False)
        assert w.table.f["hull_x1"][0] == pytest.approx(0.65, abs=1e-6)
        assert w.table.f["radius"][0] < 0.35
        (a, b, _, d), = robot_penetrations(w)
        assert w.body_label(b)[0] == "crate" and d == pytest.approx(-0.02, abs=1e-3)
        assert brute_force(w, np.arange(1)).keys() == {frozenset((a, b))}


def test_hull_is_the_chassis_box_of_the_course_robot():
    with World(physics_hz=10) as w:
        w.spawn_robot("r", Pose2D(1.0, 2.0, 0.7))
        spec, f = w.robot_spec("r"), w.table.f
        hx = spec.chassis.size[0] / 2
        hy = max(spec.chassis.size[1] / 2, spec.wheels.separation / 2 + spec.wheels.width / 2)
        assert (f["hull_x0"][0], f["hull_x1"][0]) == pytest.approx((-hx, hx), abs=1e-6)
        assert (f["hull_y0"][0], f["hull_y1"][0]) == pytest.approx((-hy, hy), abs=1e-6)
        assert math.hypot(hx, hy) == pytest.approx(f["radius"][0])  # the footprint circle's corners


@pytest.mark.parametrize("yaw", [0.0, math.pi / 4, 0.3])
def test_separating_axis_test_against_closed_form(yaw: float):
    """Unit square at the origin vs a square of half side h turned by yaw, moved along x: they touch when the
    gap between centres is 0.5 + h (|cos yaw| + |sin yaw|) (the turned square's half width along x)."""
    h = 0.3
    touch = 0.5 + h * (abs(math.cos(yaw)) + abs(math.sin(yaw)))
    one = np.ones(1)
    for gap, expect in ((touch - 1e-6, True), (touch + 1e-6, False)):
        got = boxes_overlap(np.zeros(1), np.zeros(1), one, np.zeros(1), 0.5 * one, 0.5 * one,
                            np.array([gap]), np.zeros(1), np.array([math.cos(yaw)]), np.array([math.sin(yaw)]),
                            h * one, h * one)
        assert bool(got[0]) is expect
    # corner to corner along the diagonal: separated only by the rectangles' own axes' projections
    diag = boxes_overlap(np.zeros(1), np.zeros(1), one, np.zeros(1), 0.5 * one, 0.5 * one, np.array([0.8]),
                         np.array([0.8]), one, np.zeros(1), 0.3 * one, 0.3 * one)
    assert bool(diag[0])  # 0.8 ≤ 0.5 + 0.3 on both axes: touching corners count


def test_resolution_with_the_broadphase_matches_resolution_with_brute_force(monkeypatch: pytest.MonkeyPatch):
    """Two identical dense crowds driven alike, one resolving collisions from every robot × body pair: the
    same poses, the same blocked robots and the same contacts after every step."""

    def every_pair(w: World, rows: np.ndarray) -> list[tuple[int, int]]:
        ground = w.models.ground_uids()
        every = [pb.getBodyUniqueId(k, physicsClientId=w.client)
                 for k in range(pb.getNumBodies(physicsClientId=w.client))]
        seen: set[frozenset[int]] = set()
        out = []
        for a in w.table.body[rows].tolist():
            for b in every:
                if b != a and b not in ground and frozenset((a, b)) not in seen:
                    seen.add(frozenset((a, b)))
                    out.append((a, b))
        return out

    def crowd() -> World:
        w = World(physics_hz=10, seed=5)
        for k, (x, y) in enumerate([(x, y) for x in np.arange(-3, 3.1, 1.0) for y in np.arange(-3, 3.1, 1.0)]):
            w.spawn_robot(f"r{k}", Pose2D(float(x), float(y), float(w.rng.uniform(-3, 3))))
        add_static(w, "crate", Box((0.8, 0.5, 1.0)), 0.5, 0.5, 0.4)
        add_static(w, "pillar", Cylinder(0.3, 1.0), -1.5, 1.5)
        for side, (x, y, sx, sy) in enumerate([(0, 4.0, 9, 0.2), (0, -4.0, 9, 0.2), (4.0, 0, 0.2, 9),
                                               (-4.0, 0, 0.2, 9)]):
            add_static(w, f"fence{side}", Box((sx, sy, 1.0)), x, y)
        return w

    fast, slow = crowd(), crowd()
    fast_pairs = cq.candidate_pairs
    rng = np.random.default_rng(9)
    blocked = 0
    try:
        for _ in range(40):
            v, om = rng.uniform(-1, 1, len(fast.table)), rng.uniform(-2, 2, len(fast.table))
            for w, pairs in ((fast, fast_pairs), (slow, every_pair)):
                monkeypatch.setattr(cq, "candidate_pairs", pairs)
                for n, vi, wi in zip(w.robot_names(), v.tolist(), om.tolist(), strict=True):
                    w.set_cmd_vel(n, vi, wi)
                w.step()
            for col in ("x", "y", "yaw"):
                assert np.array_equal(fast.table.f[col], slow.table.f[col])
            assert np.array_equal(fast.table.b["in_collision"], slow.table.b["in_collision"])
            blocked += int(fast.table.b["in_collision"].sum())
            for n in fast.robot_names():
                a = sorted((c.other, c.position, c.normal_force) for c in fast.latest_contacts(n).contacts)
                b = sorted((c.other, c.position, c.normal_force) for c in slow.latest_contacts(n).contacts)
                assert a == b
        assert blocked > 20  # the crowd did collide
    finally:
        fast.close()
        slow.close()
