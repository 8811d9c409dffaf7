"""Sensors at their sim-time rates and against closed forms (IMU at rest, odometry without slip)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import ImuReading, Pose2D, World, default_robot_path, load_robot_spec


def test_each_sensor_publishes_at_its_rate_in_sim_time(world: World):
    world.spawn_robot("r", Pose2D())
    counts: dict[str, int] = {}
    world.subscribe(lambda r: counts.__setitem__(type(r).__name__, counts.get(type(r).__name__, 0) + 1),
                    kinds=("scan", "imu", "odom"))
    world.run_for(2.0)
    assert counts == {"LidarScan": 20, "ImuReading": 200, "OdometryReading": 100}


def test_imu_at_rest_reads_gravity_plus_bias():
    spec = load_robot_spec(default_robot_path())
    spec = spec.model_copy(update={"sensors": spec.sensors.model_copy(update={
        "imu": spec.sensors.imu.model_copy(update={"accel_bias": (0.1, -0.05, 0.02), "gyro_bias": (0, 0, 0.01)})})})
    with World(physics_hz=100, seed=0) as w:
        w.spawn_robot("r", Pose2D(), spec=spec)
        acc: list[tuple[float, float, float]] = []
        gyr: list[tuple[float, float, float]] = []

        def on_imu(r: object) -> None:
            assert isinstance(r, ImuReading)
            acc.append(r.linear_acceleration)
            gyr.append(r.angular_velocity)

        w.subscribe(on_imu, kinds=("imu",))
        w.run_for(5.0)
    a, g = np.array(acc), np.array(gyr)
    assert a.mean(0) == pytest.approx([0.1, -0.05, 9.81 + 0.02], abs=0.006)
    assert g.mean(0)[2] == pytest.approx(0.01, abs=0.001)
    assert a.std(0)[0] == pytest.approx(spec.sensors.imu.accel_noise_std, rel=0.15)


def test_odometry_without_slip_matches_ground_truth_and_with_slip_drifts():
    base = load_robot_spec(default_robot_path())

    def run(slip: float) -> float:
        spec = base.model_copy(update={"sensors": base.sensors.model_copy(update={
            "odometry": base.sensors.odometry.model_copy(update={"slip_std": slip})})})
        with World(physics_hz=100, seed=1) as w:
            w.spawn_robot("r", Pose2D(1.0, 2.0, 0.3), spec=spec)
            w.set_cmd_vel("r", 0.6, 0.3)
            w.run_for(20.0)
            odo = w.latest_odometry("r")
            truth = w.robot_pose("r")
            assert odo is not None
            return math.hypot(odo.pose.x - truth.x, odo.pose.y - truth.y)

    assert run(0.0) < 1e-3
    assert run(0.05) > 0.02


def test_lidar_in_empty_world_sees_nothing(world: World):
    world.spawn_robot("r", Pose2D())
    world.run_for(0.1)
    scan = world.latest_scan("r")
    assert scan is not None
    assert scan.ranges.size == 360
    assert np.isinf(scan.ranges).all()
    assert scan.angle_increment == pytest.approx(math.radians(1.0))


def test_lidar_dropout_injection_stops_scans(world: World):
    world.spawn_robot("r", Pose2D())
    world.run_for(0.5)
    stamp = world.latest_scan("r").stamp  # type: ignore[union-attr]
    world.set_sensor_fault("r", "lidar", dropout=True)
    world.run_for(1.0)
    assert world.latest_scan("r").stamp == stamp  # type: ignore[union-attr]
    world.set_sensor_fault("r", "lidar", dropout=False)
    world.run_for(0.2)
    assert world.latest_scan("r").stamp > stamp  # type: ignore[union-attr]
