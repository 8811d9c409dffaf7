"""IMU and wheel odometry for all due robots at once (array operations over the robot table)."""

from __future__ import annotations

import numpy as np

from sim.robot_table import RobotTable
from sim.transforms import rpy_to_quat
from sim.types import ImuReading, OdometryReading, Pose2D

GRAVITY = 9.81


def sample_imu(t: RobotTable, due: np.ndarray, rng: np.random.Generator, now: float) -> None:
    """Planar-motion IMU: specific force (dv/dt, v·ω, g) and rate (0, 0, ω) in the body frame, plus bias
    and white noise. `due` is a boolean row mask."""
    f = t.f
    n = int(due.sum())
    if n == 0:
        return
    # Every robot due (the common case): slices are views, not ~50 boolean gathers of the whole fleet.
    sel: np.ndarray | slice = slice(None) if n == due.size else due
    dt = np.maximum(now - f["imu_stamp"][sel], 1e-9)
    ax = (f["v"][sel] - f["prev_v"][sel]) / dt
    ay = f["v"][sel] * f["w"][sel]
    scale = f["imu_noise_scale"][sel]
    noise = rng.normal(0.0, 1.0, (n, 6))
    an = (f["imu_accel_std"][sel] * scale)[:, None] * noise[:, :3]
    gn = (f["imu_gyro_std"][sel] * scale)[:, None] * noise[:, 3:]
    f["imu_ax"][sel] = ax + f["imu_bax"][sel] + an[:, 0]
    f["imu_ay"][sel] = ay + f["imu_bay"][sel] + an[:, 1]
    f["imu_az"][sel] = GRAVITY + f["imu_baz"][sel] + an[:, 2]
    f["imu_gx"][sel] = f["imu_bgx"][sel] + gn[:, 0]
    f["imu_gy"][sel] = f["imu_bgy"][sel] + gn[:, 1]
    f["imu_gz"][sel] = f["w"][sel] + f["imu_bgz"][sel] + gn[:, 2]
    f["imu_stamp"][sel] = now
    f["prev_v"][sel] = f["v"][sel]
    f["prev_w"][sel] = f["w"][sel]


def sample_odometry(t: RobotTable, due: np.ndarray, rng: np.random.Generator, now: float) -> None:
    """Encoder odometry: wheel increments since the last sample, corrupted by slip noise, integrated with the
    radius the robot believes it has. It drifts from ground truth the way a real robot's does."""
    f = t.f
    n = int(due.sum())
    if n == 0:
        return
    # Every robot due (the common case): slices are views, not ~50 boolean gathers of the whole fleet.
    sel: np.ndarray | slice = slice(None) if n == due.size else due
    dl = f["wheel_l"][sel] - f["enc_l"][sel]
    dr = f["wheel_r"][sel] - f["enc_r"][sel]
    slip = (f["odom_slip_std"][sel] * f["odom_noise_scale"][sel])[:, None] * rng.normal(0.0, 1.0, (n, 2))
    r = f["wheel_radius"][sel] * f["odom_radius_scale"][sel]
    sl = dl * (1.0 + slip[:, 0]) * r
    sr = dr * (1.0 + slip[:, 1]) * r
    ds = (sl + sr) / 2
    dth = (sr - sl) / f["wheel_sep"][sel]
    mid = f["odom_yaw"][sel] + dth / 2
    f["odom_x"][sel] += ds * np.cos(mid)
    f["odom_y"][sel] += ds * np.sin(mid)
    f["odom_yaw"][sel] = (f["odom_yaw"][sel] + dth + np.pi) % (2 * np.pi) - np.pi
    dt = np.maximum(now - f["odom_stamp"][sel], 1e-9)
    f["odom_v"][sel] = ds / dt
    f["odom_w"][sel] = dth / dt
    f["enc_l"][sel] = f["wheel_l"][sel]
    f["enc_r"][sel] = f["wheel_r"][sel]
    f["odom_stamp"][sel] = now


def imu_reading(t: RobotTable, i: int, roll_pitch: tuple[float, float] = (0.0, 0.0)) -> ImuReading:
    f = t.f
    q = rpy_to_quat(roll_pitch[0], roll_pitch[1], float(f["yaw"][i]))
    return ImuReading(t.names[i], float(f["imu_stamp"][i]),
                      (float(f["imu_ax"][i]), float(f["imu_ay"][i]), float(f["imu_az"][i])),
                      (float(f["imu_gx"][i]), float(f["imu_gy"][i]), float(f["imu_gz"][i])), q)


def odometry_reading(t: RobotTable, i: int) -> OdometryReading:
    f = t.f
    return OdometryReading(t.names[i], float(f["odom_stamp"][i]),
                           Pose2D(float(f["odom_x"][i]), float(f["odom_y"][i]), float(f["odom_yaw"][i])),
                           float(f["odom_v"][i]), float(f["odom_w"][i]),
                           float(f["enc_l"][i]), float(f["enc_r"][i]))
