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
    dt = np.maximum(now - f["imu_stamp"][due], 1e-9)
    ax = (f["v"][due] - f["prev_v"][due]) / dt
    ay = f["v"][due] * f["w"][due]
    scale = f["imu_noise_scale"][due]
    noise = rng.normal(0.0, 1.0, (n, 6))
    an = (f["imu_accel_std"][due] * scale)[:, None] * noise[:, :3]
    gn = (f["imu_gyro_std"][due] * scale)[:, None] * noise[:, 3:]
    f["imu_ax"][due] = ax + f["imu_bax"][due] + an[:, 0]
    f["imu_ay"][due] = ay + f["imu_bay"][due] + an[:, 1]
    f["imu_az"][due] = GRAVITY + f["imu_baz"][due] + an[:, 2]
    f["imu_gx"][due] = f["imu_bgx"][due] + gn[:, 0]
    f["imu_gy"][due] = f["imu_bgy"][due] + gn[:, 1]
    f["imu_gz"][due] = f["w"][due] + f["imu_bgz"][due] + gn[:, 2]
    f["imu_stamp"][due] = now
    f["prev_v"][due] = f["v"][due]
    f["prev_w"][due] = f["w"][due]


def sample_odometry(t: RobotTable, due: np.ndarray, rng: np.random.Generator, now: float) -> None:
    """Encoder odometry: wheel increments since the last sample, corrupted by slip noise, integrated with the
    radius the robot believes it has. It drifts from ground truth the way a real robot's does."""
    f = t.f
    n = int(due.sum())
    if n == 0:
        return
    dl = f["wheel_l"][due] - f["enc_l"][due]
    dr = f["wheel_r"][due] - f["enc_r"][due]
    slip = (f["odom_slip_std"][due] * f["odom_noise_scale"][due])[:, None] * rng.normal(0.0, 1.0, (n, 2))
    r = f["wheel_radius"][due] * f["odom_radius_scale"][due]
    sl = dl * (1.0 + slip[:, 0]) * r
    sr = dr * (1.0 + slip[:, 1]) * r
    ds = (sl + sr) / 2
    dth = (sr - sl) / f["wheel_sep"][due]
    mid = f["odom_yaw"][due] + dth / 2
    f["odom_x"][due] += ds * np.cos(mid)
    f["odom_y"][due] += ds * np.sin(mid)
    f["odom_yaw"][due] = (f["odom_yaw"][due] + dth + np.pi) % (2 * np.pi) - np.pi
    dt = np.maximum(now - f["odom_stamp"][due], 1e-9)
    f["odom_v"][due] = ds / dt
    f["odom_w"][due] = dth / dt
    f["enc_l"][due] = f["wheel_l"][due]
    f["enc_r"][due] = f["wheel_r"][due]
    f["odom_stamp"][due] = now


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
