"""The course's "Gazebo Plugins Integration" (20 pts): the diff-drive controller configured as the assignment
lists it and consistent with the robot's geometry, and the lidar, camera and IMU each publishing through their
gazebo_ros plugin. A description with its <plugin> blocks removed fails both items."""

from __future__ import annotations

from fleet.grading.rubric import RubricReport
from sim.errors import FleetError
from sim.gazebo_plugins import diff_drive_params, is_diff_drive
from sim.types import Cylinder, Sphere
from sim.urdf_model import UrdfRobot

REL_TOL = 0.02  # plugin numbers vs the geometry
DRIVE_RATE = 50.0  # Hz, as the assignment's plugin block
SENSOR_PLUGINS = {"lidar": (("ray", "gpu_ray", "gpu_lidar", "lidar"), "libgazebo_ros_ray_sensor.so"),
                  "camera": (("camera",), "libgazebo_ros_camera.so"),
                  "imu": (("imu",), "libgazebo_ros_imu_sensor.so")}


def _close(a: float | None, b: float) -> bool:
    return a is not None and abs(a - b) <= REL_TOL * abs(b)


def diff_drive_problems(robot: UrdfRobot, wheels: list[str]) -> list[str]:
    plugins = [p for p in robot.plugins if is_diff_drive(p)]
    if not plugins:
        return ["no diff-drive plugin (libgazebo_ros_diff_drive.so)"]
    try:
        d = diff_drive_params(plugins[0], robot.source)
    except FleetError as exc:
        return [exc.message]
    out = []
    if sorted((*d.left_joints, *d.right_joints)) != sorted(wheels):
        out.append(f"drives {', '.join((*d.left_joints, *d.right_joints)) or 'no joints'}, wheels are "
                   f"{', '.join(wheels) or 'none'}")
    elif len(wheels) == 2:
        sep = robot.wheel_separation(d.left_joints[0], d.right_joints[0])
        if not _close(d.wheel_separation, sep):
            out.append(f"wheel_separation {d.wheel_separation} vs {sep:.3f} m between the wheel joints")
        radii = [c.geometry.radius for c in robot.links[robot.joints[d.left_joints[0]].child].collisions
                 if isinstance(c.geometry, Cylinder | Sphere)]
        if radii and not _close(d.wheel_radius and 2 * d.wheel_radius, 2 * radii[0]):
            diameter = f"{2 * d.wheel_radius:g}" if d.wheel_radius else "missing"
            out.append(f"wheel_diameter {diameter} vs {2 * radii[0]:.3f} m wheels")
    if not _close(d.update_rate, DRIVE_RATE):
        out.append(f"update_rate {d.update_rate} Hz (required {DRIVE_RATE:g})")
    if not d.command_topic or not d.odometry_topic:
        out.append(f"topics: command {d.command_topic or 'unnamed'}, odometry {d.odometry_topic or 'unnamed'}")
    return out


def sensor_plugin_problems(robot: UrdfRobot) -> list[str]:
    out = []
    for what, (types, filename) in SENSOR_PLUGINS.items():
        sensor = next((s for s in robot.sensors if s.type in types), None)
        if sensor is None:
            out.append(f"no {what} sensor")
        elif not any(p.filename == filename for p in sensor.plugins):
            have = ", ".join(p.filename for p in sensor.plugins) or "no plugin"
            out.append(f"{what} '{sensor.name}': {have} (needs {filename})")
    return out


def add_plugin_items(rep: RubricReport, robot: UrdfRobot, wheels: list[str]) -> None:
    drive = diff_drive_problems(robot, wheels)
    rep.add("diff_drive_plugin", "diff-drive plugin: wheel joints, separation and diameter match the geometry, "
            "topics named, 50 Hz", 10, not drive, "; ".join(drive) or "consistent", "as the assignment's block")
    sensors = sensor_plugin_problems(robot)
    rep.add("sensor_plugins", "sensor plugins: ray (lidar), camera, IMU", 10, not sensors,
            "; ".join(sensors) or "all three", ", ".join(f for _, f in SENSOR_PLUGINS.values()))
