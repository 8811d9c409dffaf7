"""Sensor calibration: IMU bias from a stationary window, camera intrinsics from the sensor model, and the
lidar mounting offset from scans taken at known robot poses against the known map.

Lidar offset: find the planar lidar pose o in base_link minimising Σ (nᵢ·(T_robot ⊕ o ⊕ pᵢ − qᵢ))² over
all scans (point-to-line ICP, Gauss–Newton, Huber weights, a shrinking correspondence gate). One scan
already fixes the offset when it sees non-parallel structure; scans from several robot poses average the
range noise and cover views that alone are degenerate (a corridor fixes nothing along its axis).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from sim.errors import ErrorCode, FleetError
from sim.perception.projection import TINY_RENDERER_OFFSET
from sim.perception.types import CameraIntrinsics, ImuBias, LidarOffsetEstimate
from sim.robot_spec import CameraSpec, DepthCameraSpec
from sim.transforms import quat_to_rpy, rpy_to_matrix, wrap_angle
from sim.types import ImuReading, LidarScan, Pose2D

GRAVITY = 9.81


def estimate_imu_bias(readings: Sequence[ImuReading], *, gravity: float = GRAVITY,
                      max_gyro_std: float | None = 0.05, min_samples: int = 20) -> ImuBias:
    """Biases from readings of a robot standing still: gyro bias = mean rate; accel bias = mean specific
    force minus the gravity reaction Rᵀ·(0, 0, g) rotated into the body by each reading's orientation.
    Raises when the window is short or the gyro spread says the robot was moving."""
    if len(readings) < min_samples:
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         f"need ≥ {min_samples} IMU readings for a bias estimate, got {len(readings)}",
                         "collect a longer stationary window")
    acc = np.array([r.linear_acceleration for r in readings], dtype=float)
    gyr = np.array([r.angular_velocity for r in readings], dtype=float)
    up = np.array([0.0, 0.0, gravity])
    reaction = np.array([rpy_to_matrix(*quat_to_rpy(r.orientation)).T @ up for r in readings])
    gyro_std = gyr.std(axis=0)
    if max_gyro_std is not None and float(gyro_std.max()) > max_gyro_std:
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         f"the IMU window is not stationary (gyro σ {float(gyro_std.max()):.3g} rad/s)",
                         f"stop the robot first, or raise max_gyro_std ({max_gyro_std})")
    accel_bias = (acc - reaction).mean(axis=0)
    return ImuBias(_t3(accel_bias), _t3(gyr.mean(axis=0)), _t3(acc.std(axis=0)), _t3(gyro_std), len(readings))


def _t3(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def camera_intrinsics(spec: CameraSpec | DepthCameraSpec, *, rendered: bool = True) -> CameraIntrinsics:
    """fx, fy, cx, cy of a camera from its sensor model (width, height, vertical FOV). `rendered=True`
    gives those of the images sim.World renders (TinyRenderer's half-pixel shift of the principal
    point); False the ideal pinhole with the principal point at the image centre."""
    offset = TINY_RENDERER_OFFSET if rendered else (0.0, 0.0)
    return CameraIntrinsics.from_fov(spec.width, spec.height, spec.fov_deg, offset)


def estimate_lidar_offset(scans: Sequence[tuple[LidarScan, Pose2D]], map_points: np.ndarray,
                          map_normals: np.ndarray, *, initial: Pose2D | None = None,
                          truth: Pose2D | None = None, max_correspondence: float = 0.5, iterations: int = 40,
                          min_gate: float = 0.05, huber: float = 0.05) -> LidarOffsetEstimate:
    """The lidar's (x, y, yaw) in base_link from (scan, true robot pose) pairs and the map outline
    (map_outline.map_outline at the lidar height)."""
    if not scans or len(map_points) == 0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "need at least one scan and a non-empty map outline",
                         "pass (scan, robot pose) pairs and map_outline(world.description, lidar height)")
    tree = cKDTree(map_points)
    local = [s.points() for s, _ in scans]
    robots = [(np.array([p.x, p.y]), _rot(p.yaw)) for _, p in scans]
    start = initial or Pose2D()
    o = np.array([start.x, start.y, start.yaw])
    gate = max_correspondence
    rms, inliers = math.inf, 0
    for _ in range(iterations):
        jtj, jtr = np.zeros((3, 3)), np.zeros(3)
        sq, count = 0.0, 0
        for pts, (t_r, r_r) in zip(local, robots, strict=True):
            r_o = _rot(o[2])
            in_base = pts @ r_o.T + o[:2]
            world = in_base @ r_r.T + t_r
            dist, idx = tree.query(world, distance_upper_bound=gate)
            ok = np.isfinite(dist)
            if not ok.any():
                continue
            n = map_normals[idx[ok]]
            res = np.einsum("ij,ij->i", n, world[ok] - map_points[idx[ok]])
            # d(world)/d(o_xy) = R_r; d(world)/d(o_yaw) = R_r · R_o · J · p, J = 90° rotation.
            nr = n @ r_r
            dyaw = (pts[ok] @ r_o.T) @ np.array([[0.0, 1.0], [-1.0, 0.0]])  # rows: J·(R_o p)
            jac = np.column_stack([nr, np.einsum("ij,ij->i", nr, dyaw)])
            w = np.minimum(1.0, huber / np.maximum(np.abs(res), 1e-12))
            jtj += jac.T @ (w[:, None] * jac)
            jtr += jac.T @ (w * res)
            sq += float(np.sum(res ** 2))
            count += int(ok.sum())
        if count < 3:
            raise FleetError(ErrorCode.NOT_FOUND,
                             "no scan point lies near the map outline",
                             "check the robot poses, the lidar height and max_correspondence")
        delta = np.linalg.solve(jtj + 1e-9 * np.eye(3), -jtr)
        o = o + delta
        o[2] = wrap_angle(float(o[2]))
        rms, inliers = math.sqrt(sq / count), count
        gate_next = max(min_gate, min(gate, 4 * rms))  # tighten the gate as the fit improves
        if np.linalg.norm(delta[:2]) < 1e-6 and abs(delta[2]) < 1e-7 and gate_next == gate:
            break
        gate = gate_next
    est = Pose2D(float(o[0]), float(o[1]), float(o[2]))
    err_xy = None if truth is None else math.hypot(est.x - truth.x, est.y - truth.y)
    err_yaw = None if truth is None else abs(wrap_angle(est.yaw - truth.yaw))
    return LidarOffsetEstimate(est, rms, inliers, len(scans), truth, err_xy, err_yaw)


def _rot(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])
