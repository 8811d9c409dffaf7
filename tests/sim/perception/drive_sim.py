"""A ground-truth differential-drive run with encoder odometry (slip) and a biased gyro, for EKF tests.

The sensor models follow sim/sensors/inertial.py: each wheel increment is scaled by (1 + N(0, slip)), the
odometry integrates the corrupted increments; the gyro reads ω + bias + N(0, σ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sim.transforms import rpy_to_quat
from sim.types import ImuReading, OdometryReading, Pose2D


@dataclass
class Drive:
    truth: list[tuple[float, Pose2D]] = field(default_factory=list)  # (stamp, pose) at every odometry tick
    odom: list[OdometryReading] = field(default_factory=list)
    imu: list[ImuReading] = field(default_factory=list)


def simulate(seed: int = 0, duration: float = 100.0, still: float = 2.0, v: float = 1.0, slip: float = 0.02,
             separation: float = 0.4, gyro_bias: float = 0.01, gyro_std: float = 0.002,
             accel_bias: tuple[float, float, float] = (0.0, 0.0, 0.0), accel_std: float = 0.02) -> Drive:
    """Stand still for `still` s, then drive at `v` with a slowly weaving yaw rate until `duration`."""
    rng = np.random.default_rng(seed)
    dt = 0.01  # physics and IMU at 100 Hz, odometry every second step (50 Hz)
    x = y = th = 0.0
    ox = oy = oth = 0.0
    out = Drive()
    dl = dr = 0.0
    for k in range(1, round(duration / dt) + 1):
        t = k * dt
        moving = t > still
        vv = v if moving else 0.0
        w = 0.4 * math.sin(0.15 * (t - still)) if moving else 0.0
        # Exact arc for the truth; wheel travel accumulates for the encoders.
        if abs(w) > 1e-12:
            x += vv / w * (math.sin(th + w * dt) - math.sin(th))
            y -= vv / w * (math.cos(th + w * dt) - math.cos(th))
        else:
            x += vv * dt * math.cos(th)
            y += vv * dt * math.sin(th)
        th += w * dt
        dl += (vv - w * separation / 2) * dt
        dr += (vv + w * separation / 2) * dt
        gyro = (0.0, 0.0, w + gyro_bias + rng.normal(0, gyro_std))
        acc = tuple(a + rng.normal(0, accel_std) for a in (accel_bias[0], accel_bias[1],
                                                               9.81 + accel_bias[2]))
        out.imu.append(ImuReading("r", t, acc, gyro, rpy_to_quat(0.0, 0.0, th)))  # type: ignore[arg-type]
        if k % 2 == 0:
            sl = dl * (1 + rng.normal(0, slip))
            sr = dr * (1 + rng.normal(0, slip))
            ds, dth = (sl + sr) / 2, (sr - sl) / separation
            ox += ds * math.cos(oth + dth / 2)
            oy += ds * math.sin(oth + dth / 2)
            oth += dth
            out.odom.append(OdometryReading("r", t, Pose2D(ox, oy, math.remainder(oth, 2 * math.pi)),
                                            ds / (2 * dt), dth / (2 * dt), 0.0, 0.0))
            out.truth.append((t, Pose2D(x, y, math.remainder(th, 2 * math.pi))))
            dl = dr = 0.0
    return out
