"""The robot spec (sim/robot_spec.py) written as URDF: links, joints and inertials for PyBullet and ROS,
plus Gazebo friction, sensor and diff-drive plugin tags so the same file runs in Gazebo classic.

Frames (docs/robot.md): base_link is on the floor under the axle centre (z = 0 when the wheels touch the
floor, so a planar pose is its pose). It has no geometry, only a 1 g point inertial at its origin: PyBullet
reports the root's inertial frame as the body pose, so this keeps the body pose equal to base_link.
Everything else hangs off it as in the spec's helpers (chassis centre at `chassis_z`, lidar at
`lidar_height`). Regenerate the committed file with `python -m sim.urdf`.
"""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from sim.inertia import Inertia, box_inertia, cylinder_inertia, sphere_inertia
from sim.robot_spec import RobotSpec, default_robot_path, load_robot_spec
from sim.types import Box, Cylinder, Pose3D, Sphere

FRAME_MASS = 0.001  # kg: sensor and reference frames are points with a token inertial (URDF needs one)
FRAME_INERTIA = sphere_inertia(FRAME_MASS, 0.01)
WHEEL_RGBA = (0.1, 0.1, 0.1, 1.0)
METAL_RGBA = (0.6, 0.6, 0.6, 1.0)
OPTICAL_RPY = (-math.pi / 2, 0.0, -math.pi / 2)  # REP-103 camera optical frame: z forward, x right, y down
Shape = Box | Cylinder | Sphere
_ZERO = Pose3D()


@dataclass(frozen=True, slots=True)
class Part:
    """One link and the joint that attaches it to its parent (none for the root)."""

    link: str
    parent: str | None = None
    joint_type: str = "fixed"
    origin: Pose3D = _ZERO  # joint origin in the parent link's frame
    shape: Shape | None = None  # visual == collision geometry
    shape_origin: Pose3D = _ZERO
    mass: float = FRAME_MASS
    inertia: Inertia = FRAME_INERTIA
    rgba: tuple[float, float, float, float] | None = None
    friction: tuple[float, float, float] | None = None  # lateral, rolling, spinning

    @property
    def joint(self) -> str:
        return self.link.removesuffix("_link") + "_joint"


def robot_parts(spec: RobotSpec) -> list[Part]:
    """The robot as a list of parts, parents before children."""
    c, w, k, m = spec.chassis, spec.wheels, spec.caster, spec.mast
    sx, _, sz = c.size
    # Cylinders are along z in URDF; a wheel's axle is the link's y axis: roll the shape by -90°.
    wheel_shape_origin = Pose3D(roll=-math.pi / 2)
    wheel_inertia = cylinder_inertia(w.mass, w.radius, w.width, axis="y")
    wheel_friction = (w.friction, w.rolling_friction, w.spinning_friction)
    # Same mount as sim.sensors.camera.camera_mount: 1 cm ahead of the front face, 3 cm below its top.
    camera_origin = Pose3D(sx / 2 + 0.01, 0.0, sz / 2 - 0.03)
    return [
        Part("base_link"),
        Part("chassis_link", "base_link", origin=Pose3D(z=spec.chassis_z), shape=Box(c.size),
             mass=c.mass, inertia=box_inertia(c.mass, c.size), rgba=c.rgba),
        *(Part(f"{side}_wheel_link", "base_link", "continuous", Pose3D(0.0, sign * w.separation / 2,
                                                                        w.radius),
               Cylinder(w.radius, w.width), wheel_shape_origin, w.mass, wheel_inertia, WHEEL_RGBA,
               wheel_friction)
          for side, sign in (("left", 1.0), ("right", -1.0))),
        # The caster's x_offset is relative to the chassis centre; its sphere touches the floor.
        Part("caster_link", "chassis_link", origin=Pose3D(k.x_offset, 0.0, k.radius - spec.chassis_z),
             shape=Sphere(k.radius), mass=k.mass, inertia=sphere_inertia(k.mass, k.radius), rgba=METAL_RGBA,
             friction=(k.friction, 0.0, 0.0)),
        Part("mast_link", "chassis_link", origin=Pose3D(m.x_offset, 0.0, sz / 2 + m.height / 2),
             shape=Cylinder(m.radius, m.height), mass=m.mass,
             inertia=cylinder_inertia(m.mass, m.radius, m.height), rgba=METAL_RGBA),
        Part("lidar_link", "mast_link", origin=Pose3D(z=m.height / 2 + spec.sensors.lidar.mount_z)),
        Part("camera_link", "chassis_link", origin=camera_origin),
        Part("camera_optical_link", "camera_link", origin=Pose3D(0.0, 0.0, 0.0, *OPTICAL_RPY)),
        # RGB and depth share the mount: the simulator renders both from one pose.
        Part("depth_camera_link", "chassis_link", origin=camera_origin),
        Part("depth_camera_optical_link", "depth_camera_link", origin=Pose3D(0.0, 0.0, 0.0, *OPTICAL_RPY)),
        Part("imu_link", "chassis_link"),  # over the axle centre, so it feels no lever-arm acceleration
    ]


def num(v: float) -> str:
    """12 significant digits, shortest form: drops float noise (0.5700000000000001) but keeps pi/2 exact
    to ~1e-12, so the wheels touch the floor to within a picometre."""
    s = repr(float(f"{v:.12g}"))
    s = s.removesuffix(".0") if "e" not in s else s
    return "0" if s == "-0" else s


def nums(values: tuple[float, ...] | list[float]) -> str:
    return " ".join(num(v) for v in values)


def _origin(parent: ET.Element, pose: Pose3D) -> None:
    ET.SubElement(parent, "origin", xyz=nums(pose.position), rpy=nums((pose.roll, pose.pitch, pose.yaw)))


def _geometry(parent: ET.Element, shape: Shape) -> None:
    g = ET.SubElement(parent, "geometry")
    if isinstance(shape, Box):
        ET.SubElement(g, "box", size=nums(shape.size))
    elif isinstance(shape, Cylinder):
        ET.SubElement(g, "cylinder", radius=num(shape.radius), length=num(shape.length))
    else:
        ET.SubElement(g, "sphere", radius=num(shape.radius))


def _link(part: Part) -> ET.Element:
    link = ET.Element("link", name=part.link)
    inertial = ET.SubElement(link, "inertial")
    _origin(inertial, Pose3D())  # every shape is centred on its link origin
    ET.SubElement(inertial, "mass", value=num(part.mass))
    i = part.inertia
    ET.SubElement(inertial, "inertia", ixx=num(i.ixx), ixy=num(i.ixy), ixz=num(i.ixz), iyy=num(i.iyy),
                  iyz=num(i.iyz), izz=num(i.izz))
    if part.shape is not None:
        visual = ET.SubElement(link, "visual", name=part.link.removesuffix("_link") + "_visual")
        _origin(visual, part.shape_origin)
        _geometry(visual, part.shape)
        ET.SubElement(ET.SubElement(visual, "material", name=part.link.removesuffix("_link")), "color",
                      rgba=nums(part.rgba or METAL_RGBA))
        collision = ET.SubElement(link, "collision", name=part.link.removesuffix("_link") + "_collision")
        _origin(collision, part.shape_origin)
        _geometry(collision, part.shape)
    if part.friction is not None:  # PyBullet's URDF extension for per-link contact parameters
        contact = ET.SubElement(link, "contact")
        for tag, value in zip(("lateral_friction", "rolling_friction", "spinning_friction"), part.friction,
                              strict=True):
            ET.SubElement(contact, tag, value=num(value))
    return link


def _joint(part: Part, spec: RobotSpec) -> ET.Element:
    joint = ET.Element("joint", name=part.joint, type=part.joint_type)
    ET.SubElement(joint, "parent", link=part.parent or "")
    ET.SubElement(joint, "child", link=part.link)
    _origin(joint, part.origin)
    if part.joint_type == "continuous":
        ET.SubElement(joint, "axis", xyz="0 1 0")
        ET.SubElement(joint, "limit", effort=num(spec.wheels.max_torque), velocity=num(max_wheel_speed(spec)))
    return joint


def max_wheel_speed(spec: RobotSpec) -> float:
    """Wheel rate (rad/s) at full forward and turn speed together: (v + ω·s/2) / r."""
    lim, w = spec.limits, spec.wheels
    return (lim.max_linear + lim.max_angular * w.separation / 2) / w.radius


def robot_urdf(spec: RobotSpec) -> str:
    """The URDF text of `spec` (deterministic: the same spec gives the same bytes)."""
    robot = ET.Element("robot", name=spec.name)
    robot.append(ET.Comment(f" Generated by sim.urdf.robot_urdf from the RobotSpec '{spec.name}'. Do not "
                            "edit: change the robot YAML and run `python -m sim.urdf` (docs/robot.md). "))
    parts = robot_parts(spec)
    for part in parts:
        robot.append(_link(part))
        if part.parent is not None:
            robot.append(_joint(part, spec))
    robot.extend(_gazebo_friction(parts))
    robot.extend(_gazebo_plugins(spec))
    ET.indent(robot, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


# ---- Gazebo classic: friction per link, the diff-drive plugin, sensors ---------------------------------


def _tags(parent: ET.Element, **values: str) -> ET.Element:
    for tag, text in values.items():
        ET.SubElement(parent, tag).text = text
    return parent


def _gazebo_friction(parts: list[Part]) -> list[ET.Element]:
    """ODE friction (mu1 along the rolling direction, mu2 across it) for the links that touch the floor."""
    out = []
    for part in parts:
        if part.friction is not None:
            mu = num(part.friction[0])
            out.append(_tags(ET.Element("gazebo", reference=part.link), mu1=mu, mu2=mu, kp="1000000",
                             kd="100", minDepth="0.001"))
    return out


def _plugin(parent: ET.Element, name: str, filename: str, remap: tuple[str, ...] = (),
            **params: str) -> ET.Element:
    plugin = ET.SubElement(parent, "plugin", name=name, filename=filename)
    if remap:
        ros = ET.SubElement(plugin, "ros")
        for r in remap:
            ET.SubElement(ros, "remapping").text = r
    return _tags(plugin, **params)


def _sensor(link: str, name: str, kind: str, rate: float) -> tuple[ET.Element, ET.Element]:
    gz = ET.Element("gazebo", reference=link)
    sensor = _tags(ET.SubElement(gz, "sensor", name=name, type=kind), always_on="true", visualize="false",
                   update_rate=num(rate))
    return gz, sensor


def _noise(parent: ET.Element, stddev: float) -> None:
    _tags(ET.SubElement(parent, "noise"), type="gaussian", mean="0", stddev=num(stddev))


def _camera(sensor: ET.Element, fov_deg: float, width: int, height: int, near: float, far: float,
            fmt: str) -> ET.Element:
    # Gazebo's horizontal_fov: the spec's fov_deg is taken as the horizontal field of view (docs/robot.md).
    cam = _tags(ET.SubElement(sensor, "camera"), horizontal_fov=num(math.radians(fov_deg)))
    _tags(ET.SubElement(cam, "image"), width=str(width), height=str(height), format=fmt)
    _tags(ET.SubElement(cam, "clip"), near=num(near), far=num(far))
    return cam


def _gazebo_plugins(spec: RobotSpec) -> list[ET.Element]:
    s, w, out = spec.sensors, spec.wheels, []
    # The plugin limits each wheel's rim acceleration (m/s²): linear plus turning share at the limits.
    rim_accel = spec.limits.max_linear_accel + spec.limits.max_angular_accel * w.separation / 2
    drive = ET.Element("gazebo")
    _plugin(drive, "diff_drive", "libgazebo_ros_diff_drive.so", ("cmd_vel:=cmd_vel", "odom:=odom"),
            update_rate=num(s.odometry.rate_hz), left_joint="left_wheel_joint",
            right_joint="right_wheel_joint", wheel_separation=num(w.separation),
            wheel_diameter=num(2 * w.radius), max_wheel_torque=num(w.max_torque),
            max_wheel_acceleration=num(rim_accel), command_topic="cmd_vel", odometry_topic="odom",
            odometry_frame="odom", robot_base_frame="base_link", publish_odom="true", publish_odom_tf="true",
            publish_wheel_tf="true")
    out.append(drive)
    if s.lidar.enabled:  # same beam layout as sim.sensors.lidar: angle_min, then fov/beams steps
        lid = s.lidar
        inc = math.radians(lid.fov_deg) / lid.beams
        amin = -math.pi if lid.fov_deg >= 360 else -math.radians(lid.fov_deg) / 2
        gz, sensor = _sensor("lidar_link", "lidar", "ray", lid.rate_hz)
        ray = ET.SubElement(sensor, "ray")
        _tags(ET.SubElement(ET.SubElement(ray, "scan"), "horizontal"), samples=str(lid.beams), resolution="1",
              min_angle=num(amin), max_angle=num(amin + inc * (lid.beams - 1)))
        _tags(ET.SubElement(ray, "range"), min=num(lid.range_min), max=num(lid.range_max), resolution="0.01")
        _noise(ray, lid.noise_std)
        _plugin(sensor, "lidar_plugin", "libgazebo_ros_ray_sensor.so", ("~/out:=scan",),
                output_type="sensor_msgs/LaserScan", frame_name="lidar_link")
        out.append(gz)
    if s.camera.enabled:
        cam = s.camera
        gz, sensor = _sensor("camera_link", "camera", "camera", cam.rate_hz)
        _camera(sensor, cam.fov_deg, cam.width, cam.height, cam.near, cam.far, "R8G8B8")
        _plugin(sensor, "camera_plugin", "libgazebo_ros_camera.so", frame_name="camera_optical_link")
        out.append(gz)
    if s.depth.enabled:
        dep = s.depth
        gz, sensor = _sensor("depth_camera_link", "depth_camera", "depth", dep.rate_hz)
        _noise(_camera(sensor, dep.fov_deg, dep.width, dep.height, dep.range_min, dep.range_max, "R8G8B8"),
               dep.noise_std)
        _plugin(sensor, "depth_camera_plugin", "libgazebo_ros_camera.so",
                frame_name="depth_camera_optical_link", min_depth=num(dep.range_min),
                max_depth=num(dep.range_max))
        out.append(gz)
    if s.imu.enabled:
        gz, sensor = _sensor("imu_link", "imu", "imu", s.imu.rate_hz)
        imu = ET.SubElement(sensor, "imu")
        noise = (("angular_velocity", s.imu.gyro_noise_std), ("linear_acceleration", s.imu.accel_noise_std))
        for group, std in noise:
            g = ET.SubElement(imu, group)
            for axis in "xyz":
                _noise(ET.SubElement(g, axis), std)
        _plugin(sensor, "imu_plugin", "libgazebo_ros_imu_sensor.so", ("~/out:=imu",), frame_name="imu_link",
                initial_orientation_as_reference="false")
        out.append(gz)
    return out


def write_robot_urdf(spec: RobotSpec, path: str | Path) -> Path:
    out = Path(path)
    out.write_text(robot_urdf(spec), encoding="utf-8")
    return out


def robot_frames(spec: RobotSpec) -> dict[str, Pose3D]:
    """Every link's pose in base_link at zero wheel angles (camera mount, lidar, IMU ...)."""
    from sim.urdf_parser import parse_urdf  # the one forward-kinematics implementation

    return parse_urdf(robot_urdf(spec)).link_poses()


def main(argv: list[str]) -> None:
    spec_path = Path(argv[0]) if argv else default_robot_path()
    out = Path(argv[1]) if len(argv) > 1 else spec_path.with_suffix(".urdf")
    print(write_robot_urdf(load_robot_spec(spec_path), out))


if __name__ == "__main__":
    main(sys.argv[1:])
