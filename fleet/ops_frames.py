"""FleetService operations on what a robot is made of: its frames (REP-105 tree), wheel joints, sensors.

Frames: `map` (= `world`); per robot `<r>/odom`, `<r>/base_link` (or just `<r>`), `<r>/lidar`,
`<r>/camera`, `<r>/depth_camera`, `<r>/imu`; every world model by its name. map → odom is what wheel
odometry has drifted by (ground truth ⊕ odometry⁻¹), so it starts as the identity at spawn.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fleet.core import ServiceCore
from sim.errors import ErrorCode, FleetError, unknown_name
from sim.perception.overlay import lidar_in_base
from sim.transforms import se2_compose, se2_inverse
from sim.types import Pose3D

ROBOT_FRAMES = ("odom", "base_link", "lidar", "camera", "depth_camera", "imu")
SENSOR_TYPES = ("lidar", "camera", "depth", "imu", "odom", "contact")


class FrameOps(ServiceCore):
    """Mixed into FleetService."""

    def frames(self, robot: str | None = None) -> list[str]:
        def do() -> list[str]:
            robots = [self.registry.get(robot).name] if robot else self.world.robot_names()
            out = ["map"] + [f"{r}/{f}" for r in robots for f in ROBOT_FRAMES]
            return out if robot else out + list(self.world.models.names())

        return self.call(do)

    def transform(self, parent: str, child: str) -> dict[str, Any]:
        """The pose of `child` in `parent` (T_parent_child) now, with the quaternion (x, y, z, w)."""

        def do() -> dict[str, Any]:
            t = np.linalg.inv(self._frame(parent).matrix()) @ self._frame(child).matrix()
            p = Pose3D.from_matrix(t)
            return {"parent": parent, "child": child, "stamp": self.world.time,
                    "translation": [round(v, 6) for v in p.position],
                    "rpy": [round(v, 6) for v in (p.roll, p.pitch, p.yaw)],
                    "quaternion": [round(v, 6) for v in p.quaternion]}

        return self.call(do)

    def _frame(self, name: str) -> Pose3D:
        """The frame's pose in the map frame."""
        if name in ("map", "world"):
            return Pose3D()
        robot, _, part = name.partition("/")
        if self.world.table.has(robot):
            part = part or "base_link"
            p = self.world.robot_pose(robot)
            base = Pose3D(p.x, p.y, 0.0, 0.0, 0.0, p.yaw)
            spec = self.world.robot_spec(robot)
            if part == "odom":
                odom = self.world.latest_odometry(robot)
                if odom is None:
                    return Pose3D()  # before the first odometry sample odom coincides with map at spawn
                x, y, yaw = se2_compose(p.as_tuple(), se2_inverse(odom.pose.as_tuple()))
                return Pose3D(x, y, 0.0, 0.0, 0.0, yaw)
            mounts = {"base_link": Pose3D(), "lidar": lidar_in_base(spec), "camera": spec.camera_mount,
                      "depth_camera": spec.camera_mount, "imu": Pose3D(0.0, 0.0, spec.chassis_z)}
            if part not in mounts:
                raise unknown_name("frame", name, [f"{robot}/{f}" for f in ROBOT_FRAMES], ErrorCode.INVALID_ARGUMENT)
            return base.compose(mounts[part])
        if not part and name in self.world.models.names():
            return self.world.get_model_state(name).pose
        raise FleetError(ErrorCode.NOT_FOUND, f"unknown frame '{name}'",
                         "frames: map, <robot>/{" + ",".join(ROBOT_FRAMES) + "}, or a model name (list_frames)")

    def joint_states(self, robot: str) -> dict[str, Any]:
        """Wheel joints: accumulated angle (rad) and rate (rad/s) from the true wheel motion."""

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            w = self.world
            i, spec = w.table.index(robot), w.robot_spec(robot)
            v, om = w.robot_twist(robot)
            half, r = spec.wheels.separation / 2, spec.wheels.radius
            f = w.table.f
            return {"robot": robot, "stamp": w.time, "joints": [
                {"name": "left_wheel_joint", "position": float(f["wheel_l"][i]), "velocity": (v - om * half) / r},
                {"name": "right_wheel_joint", "position": float(f["wheel_r"][i]), "velocity": (v + om * half) / r}]}

        return self.call(do)

    def list_sensors(self, robot: str | None = None, sensor_type: str | None = None) -> list[dict[str, Any]]:
        """Every sensor of every robot (or one robot / one type): rate, frame, key figures, latest stamp."""
        if sensor_type is not None and sensor_type not in SENSOR_TYPES:
            raise unknown_name("sensor type", sensor_type, SENSOR_TYPES, ErrorCode.INVALID_ARGUMENT)

        def do() -> list[dict[str, Any]]:
            robots = [self.registry.get(robot).name] if robot else self.world.robot_names()
            out = []
            for r in robots:
                for d in self._sensors_of(r):
                    if sensor_type is None or d["type"] == sensor_type:
                        out.append(d)
            return out

        return self.call(do)

    def _sensors_of(self, r: str) -> list[dict[str, Any]]:
        s, w = self.world.robot_spec(r).sensors, self.world
        scan, imu, odom = w.latest_scan(r), w.latest_imu(r), w.latest_odometry(r)
        return [
            {"robot": r, "name": f"{r}/lidar", "type": "lidar", "frame": f"{r}/lidar", "enabled": s.lidar.enabled,
             "rate_hz": s.lidar.rate_hz, "beams": s.lidar.beams, "fov_deg": s.lidar.fov_deg,
             "range": [s.lidar.range_min, s.lidar.range_max], "latest": None if scan is None else scan.stamp},
            {"robot": r, "name": f"{r}/camera", "type": "camera", "frame": f"{r}/camera", "enabled": s.camera.enabled,
             "rate_hz": s.camera.rate_hz, "resolution": [s.camera.width, s.camera.height],
             "fov_deg": s.camera.fov_deg, "latest": None, "note": "rendered on request"},
            {"robot": r, "name": f"{r}/depth", "type": "depth", "frame": f"{r}/depth_camera",
             "enabled": s.depth.enabled, "rate_hz": s.depth.rate_hz, "resolution": [s.depth.width, s.depth.height],
             "range": [s.depth.range_min, s.depth.range_max], "latest": None, "note": "rendered on request"},
            {"robot": r, "name": f"{r}/imu", "type": "imu", "frame": f"{r}/imu", "enabled": s.imu.enabled,
             "rate_hz": s.imu.rate_hz, "latest": None if imu is None else imu.stamp},
            {"robot": r, "name": f"{r}/odom", "type": "odom", "frame": f"{r}/odom", "enabled": s.odometry.enabled,
             "rate_hz": s.odometry.rate_hz, "latest": None if odom is None else odom.stamp},
            {"robot": r, "name": f"{r}/contact", "type": "contact", "frame": f"{r}/base_link", "enabled": s.contact,
             "rate_hz": w.physics_hz, "latest": w.time},
        ]
