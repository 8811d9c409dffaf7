"""What a robot description's Gazebo plugins say about its drive: the diff-drive plugin of Gazebo classic
(`libgazebo_ros_diff_drive.so`, ROS 2 and ROS 1 parameter names) and of Gazebo Sim
(`gz-sim-diff-drive-system`, `gz::sim::systems::DiffDrive` and the ignition names).

Only what the plugin states is returned (None where it is silent): the caller decides what to derive from the
geometry and reports what it had to default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.errors import ErrorCode, FleetError
from sim.urdf_model import UrdfPlugin

CLASSIC_DIFF_DRIVE = ("libgazebo_ros_diff_drive.so",)
GZ_DIFF_DRIVE = ("gz-sim-diff-drive-system", "libgz-sim-diff-drive-system.so", "gz::sim::systems::DiffDrive",
                 "ignition-gazebo-diff-drive-system", "libignition-gazebo-diff-drive-system.so",
                 "ignition::gazebo::systems::DiffDrive")


@dataclass(frozen=True)
class DiffDriveParams:
    plugin: str  # the filename it came from
    left_joints: tuple[str, ...]
    right_joints: tuple[str, ...]
    wheel_separation: float | None = None
    wheel_radius: float | None = None
    update_rate: float | None = None  # odometry rate, Hz
    max_wheel_torque: float | None = None
    max_wheel_acceleration: float | None = None  # rim acceleration, m/s² (classic)
    max_linear: float | None = None  # m/s (gz)
    max_angular: float | None = None
    max_linear_accel: float | None = None
    max_angular_accel: float | None = None
    command_topic: str | None = None
    odometry_topic: str | None = None


def _is_gz(plugin: UrdfPlugin) -> bool:
    """Gazebo Sim / Ignition's DiffDrive system, by file name (any gz/ign version) or class name."""
    return (plugin.filename in GZ_DIFF_DRIVE or plugin.name in GZ_DIFF_DRIVE
            or "diff-drive-system" in plugin.filename or plugin.name.endswith("systems::DiffDrive"))


def is_diff_drive(plugin: UrdfPlugin) -> bool:
    fn = plugin.filename
    return fn in CLASSIC_DIFF_DRIVE or fn.endswith("gazebo_ros_diff_drive.so") or _is_gz(plugin)


def _num(plugin: UrdfPlugin, source: str, *keys: str) -> float | None:
    for key in keys:
        raw = plugin.param(key)
        if raw is None or raw == "":
            continue
        try:
            value = float(raw)
        except ValueError:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{source}: diff-drive parameter <{key}> is '{raw}', not a "
                             "number", "fix the plugin block") from None
        if not math.isfinite(value) or value < 0:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{source}: diff-drive parameter <{key}> is {raw}",
                             "use a finite value ≥ 0")
        return value
    return None


def _joints(plugin: UrdfPlugin, *keys: str) -> tuple[str, ...]:
    for key in keys:
        found = [v for v in plugin.params_all(key) if v]
        if found:
            return tuple(found)
    return ()


def diff_drive_params(plugin: UrdfPlugin, source: str) -> DiffDriveParams:
    gz = _is_gz(plugin)
    diameter = _num(plugin, source, "wheel_diameter", "wheelDiameter")
    radius = _num(plugin, source, "wheel_radius") if gz else (diameter / 2 if diameter is not None else None)
    return DiffDriveParams(
        plugin=plugin.filename,
        left_joints=_joints(plugin, "left_joint", "leftJoint"),
        right_joints=_joints(plugin, "right_joint", "rightJoint"),
        wheel_separation=_num(plugin, source, "wheel_separation", "wheelSeparation"),
        wheel_radius=radius,
        update_rate=_num(plugin, source, "odom_publish_frequency") if gz
        else _num(plugin, source, "update_rate", "updateRate"),
        max_wheel_torque=_num(plugin, source, "max_wheel_torque", "wheelTorque", "torque"),
        max_wheel_acceleration=_num(plugin, source, "max_wheel_acceleration", "wheelAcceleration"),
        max_linear=_num(plugin, source, "max_linear_velocity", "max_velocity"),
        max_angular=_num(plugin, source, "max_angular_velocity"),
        max_linear_accel=_num(plugin, source, "max_linear_acceleration", "max_acceleration"),
        max_angular_accel=_num(plugin, source, "max_angular_acceleration"),
        command_topic=plugin.param("topic") if gz else (plugin.param("command_topic") or
                                                          plugin.param("commandTopic")),
        odometry_topic=plugin.param("odom_topic") if gz else (plugin.param("odometry_topic") or
                                                                plugin.param("odometryTopic")),
    )
