"""Calibration against injected truth: IMU biases, and a lidar mounting offset recovered from scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.errors import FleetError
from sim.perception import estimate_imu_bias, estimate_lidar_offset, map_outline
from sim.transforms import rpy_to_matrix, rpy_to_quat, se2_compose
from sim.types import (
    Box,
    Collision,
    Cylinder,
    ImuReading,
    Link,
    ModelDescription,
    Pose2D,
    Pose3D,
    WorldDescription,
)
from tests.sim.perception.drive_sim import simulate
from tests.sim.perception.raycast2d import Circle, Rect, scan_from


def test_imu_bias_within_ten_percent_of_the_injected_bias() -> None:
    accel_bias, gyro_bias = (0.05, -0.04, 0.08), 0.012
    drive = simulate(seed=11, duration=2.0, still=2.0, gyro_bias=gyro_bias, accel_bias=accel_bias)
    est = estimate_imu_bias(drive.imu)  # 200 readings, 2 s at 100 Hz
    assert est.samples == 200
    for got, want in zip(est.accel, accel_bias, strict=True):
        assert got == pytest.approx(want, rel=0.1)
    assert est.gyro[2] == pytest.approx(gyro_bias, rel=0.1)


def test_imu_bias_on_a_slope_removes_the_tilted_gravity() -> None:
    rng = np.random.default_rng(2)
    roll, pitch = math.radians(6), math.radians(-4)
    reaction = rpy_to_matrix(roll, pitch, 0.3).T @ np.array([0, 0, 9.81])
    bias = np.array([0.03, 0.06, -0.05])
    readings = []
    for k in range(300):
        a = reaction + bias + rng.normal(0, 0.02, 3)
        g = rng.normal(0, 0.002, 3)
        readings.append(ImuReading("r", 0.01 * k, (float(a[0]), float(a[1]), float(a[2])),
                                   (float(g[0]), float(g[1]), float(g[2])), rpy_to_quat(roll, pitch, 0.3)))
    est = estimate_imu_bias(readings)
    assert np.allclose(est.accel, bias, rtol=0.1)


def test_imu_bias_refuses_a_moving_or_short_window() -> None:
    moving = simulate(seed=1, duration=4.0, still=0.5)
    with pytest.raises(FleetError, match="not stationary"):
        estimate_imu_bias(moving.imu)
    with pytest.raises(FleetError, match="IMU readings"):
        estimate_imu_bias(moving.imu[:5])


def _box_model(name: str, x: float, y: float, sx: float, sy: float, yaw: float = 0.0, h: float = 1.0
               ) -> ModelDescription:
    col = Collision("c", Box((sx, sy, h)))
    return ModelDescription(name, Pose3D(x, y, h / 2, 0, 0, yaw), True, (Link("link", collisions=(col,)),))


ROOM = WorldDescription("room", models=(
    _box_model("north", 0.0, 4.05, 10.2, 0.1), _box_model("south", 0.0, -4.05, 10.2, 0.1),
    _box_model("east", 5.05, 0.0, 0.1, 8.2), _box_model("west", -5.05, 0.0, 0.1, 8.2),
    _box_model("crate", 2.0, 1.5, 0.8, 0.6, yaw=0.5),
    ModelDescription("pillar", Pose3D(-2.0, -1.0, 0.5), True,
                     (Link("link", collisions=(Collision("c", Cylinder(0.3, 1.0)),)),)),
))
SHAPES: list[Circle | Rect] = [Rect(0.0, 4.05, 10.2, 0.1), Rect(0.0, -4.05, 10.2, 0.1),
                               Rect(5.05, 0.0, 0.1, 8.2), Rect(-5.05, 0.0, 0.1, 8.2),
                               Rect(2.0, 1.5, 0.8, 0.6, 0.5), Circle(-2.0, -1.0, 0.3)]


def test_map_outline_lies_on_the_shapes_with_outward_normals() -> None:
    pts, normals = map_outline(ROOM, height=0.5, spacing=0.05)
    assert len(pts) > 500 and np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    # Each point is on some shape's boundary: a ray cast from 1 cm outside along −normal hits at 1 cm.
    hits = []
    for p, n in zip(pts[::7], normals[::7], strict=True):
        o = p + 0.01 * n
        scan = scan_from(o[0], o[1], math.atan2(-n[1], -n[0]), SHAPES, beams=2)
        hits.append(scan.ranges[1])  # beam 1 (−π + π) points along yaw, into the shape
    assert np.allclose(hits, 0.01, atol=1e-6)
    above, _ = map_outline(ROOM, height=1.5)
    assert len(above) == 0  # every model is 1 m tall


def test_lidar_offset_recovered_from_scans_at_known_poses() -> None:
    truth = Pose2D(0.12, -0.04, math.radians(3.0))
    robots = [Pose2D(0.0, 0.0, 0.0), Pose2D(-3.0, 2.0, 1.2), Pose2D(3.5, -2.5, 2.5),
              Pose2D(-1.0, -3.0, -1.0), Pose2D(1.0, 3.0, -2.6)]
    rng = np.random.default_rng(5)
    scans = []
    for rp in robots:
        lx, ly, lyaw = se2_compose(rp.as_tuple(), truth.as_tuple())
        scans.append((scan_from(lx, ly, lyaw, SHAPES, noise=0.01, rng=rng), rp))
    pts, normals = map_outline(ROOM, height=0.5, spacing=0.02)
    est = estimate_lidar_offset(scans, pts, normals, truth=truth)
    assert est.error_xy is not None and est.error_xy < 0.01
    assert est.error_yaw is not None and est.error_yaw < math.radians(0.2)
    assert est.rms_residual < 0.02 and est.scans == 5
    naive = estimate_lidar_offset(scans, pts, normals, iterations=1, max_correspondence=0.3, truth=truth)
    assert naive.error_xy is not None and naive.error_xy > est.error_xy  # the iterations did the work
