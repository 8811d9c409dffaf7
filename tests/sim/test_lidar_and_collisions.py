"""Lidar against walls at known distances; kinematic robots never pass through obstacles or each other."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import ErrorCode, FleetError, Pose2D, World
from sim.types import Box, Collision, Cylinder, Link, ModelDescription, Pose3D, Visual


def add_box(world: World, name: str, x: float, y: float, size: tuple[float, float, float], yaw: float = 0.0) -> None:
    geom = Box(size)
    link = Link("link", collisions=(Collision("c", geom),), visuals=(Visual("v", geom),))
    world.models.add_model(ModelDescription(name, Pose3D(x, y, size[2] / 2, 0, 0, yaw), True, (link,)))
    world._sync_labels()


@pytest.mark.parametrize("fidelity", ["kinematic", "dynamic"])
def test_lidar_beam_reads_wall_distance_within_noise(fidelity: str):
    with World(physics_hz=100, seed=2, fidelity=fidelity) as w:  # type: ignore[arg-type]
        add_box(w, "wall", 3.0, 0.0, (0.2, 6.0, 1.2))  # face at x = 2.9
        add_box(w, "side", 0.0, -2.0, (6.0, 0.2, 1.2))  # face at y = -1.9
        w.spawn_robot("r", Pose2D(0, 0, 0))
        w.run_for(0.5)
        scan = w.latest_scan("r")
        assert scan is not None
        sigma = w.robot_spec("r").sensors.lidar.noise_std
        ahead = scan.ranges[180]  # angle 0: straight ahead
        right = scan.ranges[90]  # angle -pi/2
        pose = w.robot_pose("r")
        assert ahead == pytest.approx(2.9 - pose.x, abs=4 * sigma + 0.005)
        assert right == pytest.approx(1.9 + pose.y, abs=4 * sigma + 0.005)
        # A beam at 30° to the wall reads d / cos(30°).
        assert scan.ranges[210] == pytest.approx((2.9 - pose.x) / math.cos(math.radians(30)), abs=4 * sigma + 0.01)
        assert w.body_label(int(scan.hit_bodies[180]))[0] == "wall"  # type: ignore[index]


def test_robot_driving_into_a_wall_stops_at_it_and_reports_contact():
    with World(physics_hz=50, seed=0) as w:
        add_box(w, "wall", 3.0, 0.0, (0.2, 6.0, 1.0))
        w.spawn_robot("r", Pose2D(0, 0, 0))
        w.set_cmd_vel("r", 1.0, 0.0)
        touched = False
        for _ in range(300):
            w.step()
            touched |= w.latest_contacts("r").bumped
        front = w.robot_pose("r").x + 0.25  # chassis half length
        assert touched
        assert front <= 2.9 + 1e-3  # never inside the wall
        assert front > 2.9 - 0.05  # and it did get there


def test_head_on_robots_never_pass_through_each_other():
    with World(physics_hz=10, seed=0) as w:
        w.spawn_robot("a", Pose2D(-2, 0, 0))
        w.spawn_robot("b", Pose2D(2, 0, math.pi))
        w.set_cmd_vel("a", 1.0, 0.0)
        w.set_cmd_vel("b", 1.0, 0.0)
        for _ in range(60):
            w.step()
            gap = w.robot_pose("b").x - w.robot_pose("a").x
            assert gap >= 0.5 - 1e-3  # two half-lengths: never overlapping
        assert w.robot_pose("a").x < w.robot_pose("b").x


def brute_force_penetrations(w: World) -> list[tuple[int, int, float]]:
    """Independent check: every robot against every other body, measured with getClosestPoints."""
    import pybullet as pb

    robots = [int(u) for u in w.table.body]
    others = [u for u in range(pb.getNumBodies(physicsClientId=w.client))]
    bad = []
    for a in robots:
        for b in others:
            if b == a or b in w.models.ground_uids():
                continue
            d = min((c[8] for c in pb.getClosestPoints(a, b, 0.0, physicsClientId=w.client)), default=1.0)
            if d < -1e-3:
                bad.append((a, b, d))
    return bad


def test_dense_crowd_stays_collision_free():
    """Many robots with random commands in a small pen: after every step no two footprints overlap."""
    with World(physics_hz=10, seed=4) as w:
        for k, (x, y) in enumerate([(x, y) for x in np.arange(-3, 3.1, 1.5) for y in np.arange(-3, 3.1, 1.5)]):
            w.spawn_robot(f"r{k}", Pose2D(float(x), float(y), float(w.rng.uniform(-3, 3))))
        for side, (x, y, sx, sy) in enumerate([(0, 4.5, 10, 0.2), (0, -4.5, 10, 0.2), (4.5, 0, 0.2, 10),
                                               (-4.5, 0, 0.2, 10)]):
            add_box(w, f"fence{side}", x, y, (sx, sy, 1.0))
        for _ in range(100):
            for n in w.robot_names():
                w.set_cmd_vel(n, float(w.rng.uniform(-1, 1)), float(w.rng.uniform(-2, 2)))
            w.step()
            assert brute_force_penetrations(w) == []
            xs = np.array([w.robot_pose(n).x for n in w.robot_names()])
            assert np.all(np.abs(xs) < 4.4)


def test_spawning_inside_an_obstacle_is_refused_and_loses_nothing():
    with World(physics_hz=100, seed=0) as w:
        add_box(w, "crate", 0.0, 0.0, (1.0, 1.0, 1.0))
        with pytest.raises(FleetError) as e:
            w.spawn_robot("r", Pose2D(0.2, 0.0, 0.0))
        assert e.value.code is ErrorCode.COLLISION and "crate" in e.value.message
        assert w.robot_names() == []
        w.spawn_robot("r", Pose2D(3.0, 0.0, 0.0))
        w.step(5)


def test_cylinder_obstacle_distance():
    with World(physics_hz=100, seed=1) as w:
        geom = Cylinder(0.5, 1.0)
        link = Link("link", collisions=(Collision("c", geom),), visuals=(Visual("v", geom),))
        w.models.add_model(ModelDescription("pillar", Pose3D(0, 4.0, 0.5), True, (link,)))
        w._sync_labels()
        w.spawn_robot("r", Pose2D(0, 0, 0))
        w.run_for(0.1)
        scan = w.latest_scan("r")
        assert scan is not None
        assert scan.ranges[270] == pytest.approx(3.5, abs=0.05)  # +90°: the near face of the pillar
