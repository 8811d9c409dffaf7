"""A 2-D EKF in the odom frame, robot_localization style: state (x, y, yaw, v, ω), unicycle motion.

Wheel odometry updates (v, ω) — from its reported twist or from the difference of consecutive odometry
poses ("differential" mode); the IMU gyro updates ω (after subtracting a calibrated bias) and may drive
v's prediction with its forward acceleration; absolute or scan-matching poses update (x, y, yaw). Each
measurement first predicts the state to the measurement's stamp. Out-of-order stamps are applied at the
filter's current time (no history rewind).
"""

from __future__ import annotations

import math

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.perception.types import EkfConfig, EkfState
from sim.transforms import se2_between, wrap_angle
from sim.types import ImuReading, OdometryReading, Pose2D

_MAX_STEP = 0.02  # s: long gaps are integrated in sub-steps so the arc stays accurate


class Ekf:
    def __init__(self, *, initial: Pose2D | None = None, stamp: float = 0.0, accel_std: float = 1.0,
                 alpha_std: float = 2.0, odom_v_std: float = 0.05, odom_w_std: float = 0.1,
                 gyro_std: float = 0.01, pose_xy_std: float = 0.05, pose_yaw_std: float = 0.02,
                 use_accel: bool = False, initial_std: tuple[float, ...] = (1e-3, 1e-3, 1e-3, 0.1, 0.1)
                 ) -> None:
        start = initial or Pose2D()
        self._s = np.array([start.x, start.y, start.yaw, 0.0, 0.0])
        self._p = np.diag(np.square(np.asarray(initial_std, dtype=float)))
        self._t = stamp
        self._q_acc = (accel_std ** 2, alpha_std ** 2)
        self._r_odom = np.diag([odom_v_std ** 2, odom_w_std ** 2])
        self._r_gyro = np.array([[gyro_std ** 2]])
        self._r_pose = np.diag([pose_xy_std ** 2, pose_xy_std ** 2, pose_yaw_std ** 2])
        self._use_accel = use_accel
        self._accel = 0.0  # latest forward acceleration (gravity-free), used when use_accel
        self._last_odom: OdometryReading | None = None

    @property
    def state(self) -> EkfState:
        s = self._s
        return EkfState(self._t, float(s[0]), float(s[1]), float(s[2]), float(s[3]), float(s[4]),
                        self._p.copy())

    # ---- prediction -----------------------------------------------------------------------------------

    def predict(self, stamp: float) -> None:
        """Propagate the state and covariance to sim time `stamp` (no-op for a stamp in the past)."""
        if not math.isfinite(stamp):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"stamp must be finite, got {stamp}", "")
        while stamp - self._t > 1e-12:
            dt = min(_MAX_STEP, stamp - self._t)
            self._step(dt)
            self._t += dt

    def _step(self, dt: float) -> None:
        x, y, th, v, w = self._s
        thm = th + 0.5 * w * dt  # midpoint heading: second-order accurate on arcs
        c, s = math.cos(thm), math.sin(thm)
        a = self._accel if self._use_accel else 0.0
        self._s = np.array([x + v * dt * c, y + v * dt * s, wrap_angle(th + w * dt), v + a * dt, w])
        f = np.eye(5)
        f[0, 2], f[0, 3], f[0, 4] = -v * dt * s, dt * c, -0.5 * v * dt * dt * s
        f[1, 2], f[1, 3], f[1, 4] = v * dt * c, dt * s, 0.5 * v * dt * dt * c
        f[2, 4] = dt
        # White linear/angular acceleration noise enters through the kinematics.
        g = np.array([[0.5 * dt * dt * c, 0.0], [0.5 * dt * dt * s, 0.0], [0.0, 0.5 * dt * dt],
                      [dt, 0.0], [0.0, dt]])
        q = g @ np.diag(self._q_acc) @ g.T + 1e-12 * np.eye(5)
        self._p = f @ self._p @ f.T + q

    # ---- updates --------------------------------------------------------------------------------------

    def _update(self, z: np.ndarray, h: np.ndarray, r: np.ndarray, yaw_row: int | None = None) -> None:
        innov = z - h @ self._s
        if yaw_row is not None:
            innov[yaw_row] = wrap_angle(float(innov[yaw_row]))
        s = h @ self._p @ h.T + r
        k = np.linalg.solve(s, h @ self._p).T
        self._s = self._s + k @ innov
        self._s[2] = wrap_angle(float(self._s[2]))
        ikh = np.eye(5) - k @ h
        self._p = ikh @ self._p @ ikh.T + k @ r @ k.T  # Joseph form keeps P symmetric positive

    def update_odometry(self, reading: OdometryReading, *, differential: bool = False) -> None:
        """Fuse wheel odometry as a (v, ω) measurement: its twist, or (differential=True) the body-frame
        motion between this and the previous odometry pose divided by the time between them."""
        prev, self._last_odom = self._last_odom, reading
        if differential:
            if prev is None or reading.stamp <= prev.stamp:
                return  # the first reading only sets the reference
            dt = reading.stamp - prev.stamp
            dx, _, dth = se2_between(prev.pose.as_tuple(), reading.pose.as_tuple())
            z = np.array([dx / dt, dth / dt])
        else:
            z = np.array([reading.linear, reading.angular])
        self.predict(reading.stamp)
        h = np.zeros((2, 5))
        h[0, 3] = h[1, 4] = 1.0
        self._update(z, h, self._r_odom)

    def update_imu(self, reading: ImuReading, *, gyro_bias: float = 0.0, accel_bias: float = 0.0) -> None:
        """Fuse the gyro's yaw rate (minus its bias); keep the forward acceleration for the prediction."""
        self.predict(reading.stamp)
        self._accel = float(reading.linear_acceleration[0]) - accel_bias
        h = np.zeros((1, 5))
        h[0, 4] = 1.0
        self._update(np.array([float(reading.angular_velocity[2]) - gyro_bias]), h, self._r_gyro)

    def update_pose(self, pose: Pose2D, stamp: float, *, xy_std: float | None = None,
                    yaw_std: float | None = None) -> None:
        """Fuse an absolute pose in the odom frame (localization, or a scan-matcher's pose)."""
        self.predict(stamp)
        r = self._r_pose.copy()
        if xy_std is not None:
            r[0, 0] = r[1, 1] = xy_std ** 2
        if yaw_std is not None:
            r[2, 2] = yaw_std ** 2
        h = np.zeros((3, 5))
        h[0, 0] = h[1, 1] = h[2, 2] = 1.0
        self._update(np.array([pose.x, pose.y, pose.yaw]), h, r, yaw_row=2)


def make_ekf(config: EkfConfig, initial: Pose2D | None = None, stamp: float = 0.0) -> Ekf:
    """The factory: config section → keyword arguments."""
    return Ekf(initial=initial, stamp=stamp, **config.model_dump())
