"""FleetService operations that collect a window of live readings: sensor calibration (IMU bias, lidar
mounting offset, camera intrinsics) and odometry + IMU fusion with an EKF.

A session subscribes to the robot's readings on the sim thread; its result is computed from what was
collected and compared with the ground truth the world knows (the configured bias, the true mount, the
true pose). Sessions belong to one world: a reset drops them."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pydantic import ValidationError

from fleet.core import ServiceCore
from fleet.validation import summarize
from sim.errors import ErrorCode, FleetError
from sim.perception import (
    Ekf,
    EkfConfig,
    camera_intrinsics,
    estimate_imu_bias,
    estimate_lidar_offset,
    make_ekf,
    map_outline,
)
from sim.types import ImuReading, LidarScan, OdometryReading, Pose2D

CALIBRATIONS = ("imu_bias", "lidar_offset", "camera_intrinsics")
_ids = itertools.count(1)


@dataclass
class Calibration:
    id: str
    robot: str
    kind: str
    started: float
    unsubscribe: Callable[[], None] | None
    samples: list[Any] = field(default_factory=list)


@dataclass
class Fusion:
    robot: str
    ekf: Ekf
    started: float
    unsubscribe: Callable[[], None]
    updates: int = 0


class CalibrationOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_calibration_ops(self) -> None:
        self._calibrations: dict[str, Calibration] = {}
        self._fusions: dict[str, Fusion] = {}

    # ---- calibration ----------------------------------------------------------------------------------

    def start_calibration(self, robot: str, kind: str) -> dict[str, Any]:
        """Begin collecting readings for a calibration; keep the robot still, let sim time pass (≥ 1 s for the
        IMU, a few scans for the lidar), then call finish_calibration with the id."""
        if kind not in CALIBRATIONS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown calibration '{kind}'",
                             f"calibrations: {', '.join(CALIBRATIONS)}")

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            c = Calibration(f"cal{next(_ids)}", robot, kind, self.world.time, None)
            if kind == "imu_bias":
                c.unsubscribe = self.world.subscribe(lambda r: self._collect(c, r, ImuReading), kinds=("imu",))
            elif kind == "lidar_offset":
                c.unsubscribe = self.world.subscribe(lambda r: self._collect(c, r, LidarScan), kinds=("scan",))
            self._calibrations[c.id] = c
            return {"id": c.id, "robot": robot, "kind": kind, "started": c.started}

        return self.call(do)

    def _collect(self, c: Calibration, reading: Any, kind: type) -> None:
        if isinstance(reading, kind) and getattr(reading, "robot", None) == c.robot and self.world.table.has(c.robot):
            c.samples.append((reading, self.world.robot_pose(c.robot)))

    def finish_calibration(self, calibration_id: str) -> dict[str, Any]:
        """Stop collecting and estimate; the result carries the ground truth and the error against it."""

        def do() -> dict[str, Any]:
            c = self._calibrations.pop(calibration_id, None)
            if c is None:
                raise FleetError(ErrorCode.NOT_FOUND, f"no calibration '{calibration_id}'",
                                 f"running: {', '.join(self._calibrations) or 'none'}; start one first")
            if c.unsubscribe is not None:
                c.unsubscribe()
            out = {"id": c.id, "robot": c.robot, "kind": c.kind, "window_s": round(self.world.time - c.started, 4),
                   "samples": len(c.samples)}
            return out | self._estimate(c)

        return self.call(do)

    def _estimate(self, c: Calibration) -> dict[str, Any]:
        spec = self.world.robot_spec(c.robot) if self.world.table.has(c.robot) else self.default_spec()
        if c.kind == "camera_intrinsics":
            k, d = camera_intrinsics(spec.sensors.camera), camera_intrinsics(spec.sensors.depth)
            return {"camera": {"fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy, "width": k.width, "height": k.height},
                    "depth": {"fx": d.fx, "fy": d.fy, "cx": d.cx, "cy": d.cy, "width": d.width, "height": d.height},
                    "method": "pinhole from the renderer's projection (principal point per docs/perception.md)"}
        if c.kind == "imu_bias":
            b = estimate_imu_bias([r for r, _ in c.samples])
            truth = spec.sensors.imu
            return {"accel_bias": _r(b.accel), "gyro_bias": _r(b.gyro), "truth_accel_bias": list(truth.accel_bias),
                    "truth_gyro_bias": list(truth.gyro_bias),
                    "accel_error": round(math.dist(b.accel, truth.accel_bias), 5),
                    "gyro_error": round(math.dist(b.gyro, truth.gyro_bias), 6)}
        pts, normals = map_outline(self.world.description, spec.lidar_height)
        truth_offset = Pose2D(spec.mast.x_offset, 0.0, 0.0)
        est = estimate_lidar_offset(c.samples[-50:], pts, normals, truth=truth_offset)
        return {"offset": {"x": round(est.offset.x, 4), "y": round(est.offset.y, 4), "yaw": round(est.offset.yaw, 5)},
                "truth": {"x": truth_offset.x, "y": truth_offset.y, "yaw": truth_offset.yaw},
                "error_xy_m": None if est.error_xy is None else round(est.error_xy, 4),
                "error_yaw_rad": None if est.error_yaw is None else round(est.error_yaw, 5),
                "rms_residual_m": round(est.rms_residual, 4), "inliers": est.inliers, "scans": est.scans}

    # ---- odometry + IMU fusion -------------------------------------------------------------------------

    def start_fusion(self, robot: str, config: dict[str, Any] | None = None) -> dict[str, Any]:
        """Fuse the robot's wheel odometry and gyro in an EKF from now on (starting at its true pose)."""
        try:
            cfg = EkfConfig.model_validate(config or {})
        except ValidationError as exc:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"ekf settings: {summarize(exc)}",
                             f"fields: {', '.join(EkfConfig.model_fields)}") from exc

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            old = self._fusions.pop(robot, None)
            if old is not None:
                old.unsubscribe()
            ekf = make_ekf(cfg, self.world.robot_pose(robot), self.world.time)
            gyro_bias = self.world.robot_spec(robot).sensors.imu.gyro_bias[2]

            def on(r: Any) -> None:
                if getattr(r, "robot", None) != robot:
                    return
                if isinstance(r, OdometryReading):
                    ekf.update_odometry(r)
                elif isinstance(r, ImuReading):
                    ekf.update_imu(r, gyro_bias=gyro_bias)
                f.updates += 1

            f = Fusion(robot, ekf, self.world.time, self.world.subscribe(on, kinds=("odom", "imu")))
            self._fusions[robot] = f
            return self._fusion_dict(f)

        return self.call(do)

    def fusion_status(self, robot: str) -> dict[str, Any]:
        """The fused pose and its error against ground truth, next to raw wheel odometry's error."""

        def do() -> dict[str, Any]:
            if robot not in self._fusions:
                self.registry.get(robot)
                raise FleetError(ErrorCode.NOT_FOUND, f"no fusion running on '{robot}'", "call start_fusion first")
            return self._fusion_dict(self._fusions[robot])

        return self.call(do)

    def stop_fusion(self, robot: str) -> dict[str, Any]:
        def do() -> dict[str, Any]:
            d = self.fusion_status(robot)
            self._fusions.pop(robot).unsubscribe()
            return d | {"running": False}

        return self.call(do)

    def _fusion_dict(self, f: Fusion) -> dict[str, Any]:
        s = f.ekf.state
        truth = self.world.robot_pose(f.robot)
        odom = self.world.latest_odometry(f.robot)
        return {"robot": f.robot, "running": True, "started": f.started, "updates": f.updates, "stamp": s.stamp,
                "pose": {"x": round(s.x, 4), "y": round(s.y, 4), "yaw": round(s.yaw, 4)},
                "twist": {"v": round(s.v, 4), "w": round(s.w, 4)},
                "sigma_xy_m": round(math.sqrt(max(0.0, float(s.covariance[0, 0] + s.covariance[1, 1]))), 4),
                "truth": {"x": round(truth.x, 4), "y": round(truth.y, 4), "yaw": round(truth.yaw, 4)},
                "error_m": round(math.hypot(s.x - truth.x, s.y - truth.y), 4),
                "odometry_error_m": None if odom is None else round(odom.pose.distance_to(truth), 4)}


def _r(v: tuple[float, ...]) -> list[float]:
    return [round(float(a), 6) for a in v]
