"""Fleet state as numpy arrays, one row per robot, so hot paths are array operations, not loops.

Rows are kept in spawn order; removing a robot deletes its row (spawn/remove are rare, steps are not).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# Column names of the float state; each is a 1-D array of length n_robots.
FLOAT_COLUMNS = (
    "x", "y", "yaw",  # ground-truth pose
    "v", "w",  # ground-truth body twist (applied, after acceleration limits)
    "prev_v", "prev_w",  # twist one IMU period ago (for accelerations)
    "cmd_v", "cmd_w",  # commanded (already clamped to velocity limits)
    "sp_v", "sp_w",  # setpoint: the command after acceleration limiting (what the drive is asked for)
    "max_v", "max_w", "max_a", "max_alpha",  # limits
    "wheel_l", "wheel_r",  # true accumulated wheel angles (rad)
    "enc_l", "enc_r",  # wheel angles at the last odometry sample
    "odom_x", "odom_y", "odom_yaw", "odom_v", "odom_w",  # wheel-odometry estimate (odom frame)
    "wheel_radius", "wheel_sep", "radius",  # radius: footprint circle about base_link
    "hull_x0", "hull_x1", "hull_y0", "hull_y1",  # kinematic proxy's collision box in base_link (contact_query)
    "next_lidar", "next_imu", "next_odom",  # sim time each sensor is next due
    "lidar_period", "imu_period", "odom_period",
    "lidar_noise_scale", "imu_noise_scale", "odom_noise_scale",  # failure injection: 1 = nominal
    "imu_ax", "imu_ay", "imu_az", "imu_gx", "imu_gy", "imu_gz", "imu_stamp",  # latest IMU sample
    "odom_stamp",
    # per-robot sensor parameters (from RobotSpec), so noise is one array operation for the fleet
    "lidar_noise_std", "imu_accel_std", "imu_gyro_std",
    "imu_bax", "imu_bay", "imu_baz", "imu_bgx", "imu_bgy", "imu_bgz",
    "odom_slip_std", "odom_radius_scale",
)
BOOL_COLUMNS = ("kinematic", "lidar_dropout", "imu_dropout", "odom_dropout", "in_collision")


@dataclass
class RobotTable:
    names: list[str] = field(default_factory=list)
    f: dict[str, np.ndarray] = field(default_factory=lambda: {c: np.zeros(0) for c in FLOAT_COLUMNS})
    b: dict[str, np.ndarray] = field(default_factory=lambda: {c: np.zeros(0, bool) for c in BOOL_COLUMNS})
    body: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    _index: dict[str, int] = field(default_factory=dict)
    row_of_uid: dict[int, int] = field(default_factory=dict)  # PyBullet body uid → row (contacts name uids)

    def __len__(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        return self._index[name]

    def has(self, name: str) -> bool:
        return name in self._index

    def add(self, name: str, body_uid: int, floats: dict[str, float], bools: dict[str, bool]) -> int:
        unknown = set(floats) - set(FLOAT_COLUMNS) | set(bools) - set(BOOL_COLUMNS)
        if unknown:
            raise KeyError(f"unknown robot table columns: {sorted(unknown)}")
        self.names.append(name)
        for c in FLOAT_COLUMNS:
            self.f[c] = np.append(self.f[c], floats.get(c, 0.0))
        for c in BOOL_COLUMNS:
            self.b[c] = np.append(self.b[c], bools.get(c, False))
        self.body = np.append(self.body, body_uid)
        self._reindex()
        return len(self.names) - 1

    def remove(self, name: str) -> None:
        i = self._index[name]
        del self.names[i]
        for c in FLOAT_COLUMNS:
            self.f[c] = np.delete(self.f[c], i)
        for c in BOOL_COLUMNS:
            self.b[c] = np.delete(self.b[c], i)
        self.body = np.delete(self.body, i)
        self._reindex()

    def _reindex(self) -> None:
        self._index = {n: i for i, n in enumerate(self.names)}
        self.row_of_uid = {u: i for i, u in enumerate(self.body.tolist())}

    def copy_state(self) -> dict[str, np.ndarray]:
        """A deep copy of every column (for snapshots)."""
        out = {c: a.copy() for c, a in self.f.items()}
        out.update({f"b:{c}": a.copy() for c, a in self.b.items()})
        out["body"] = self.body.copy()
        return out

    def load_state(self, names: list[str], state: dict[str, np.ndarray]) -> None:
        self.names = list(names)
        self.f = {c: state[c].copy() for c in FLOAT_COLUMNS}
        self.b = {c: state[f"b:{c}"].copy() for c in BOOL_COLUMNS}
        self.body = state["body"].copy()
        self._reindex()
