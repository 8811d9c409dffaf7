"""A robot from a URDF (or xacro) description: the drive, limits, sensors and their mounts read from the file,
turned into a RobotSpec whose `description` is the URDF PyBullet loads.

Recipe: read (expand xacro) → parse → find the drive (the diff-drive plugin, else wheel joints by name) →
place fleetnav's base_link on the floor under the axle centre → sensors and limits → write the URDF to load.
Everything the description does not say and fleetnav needs is defaulted and listed in `warnings`; nothing
is silently guessed. The spec's chassis, caster and mast sections summarise the description for code that
reads them (masses add up to the file's total); what is simulated is the description itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.gazebo_plugins import DiffDriveParams, diff_drive_params, is_diff_drive
from sim.robot_spec import (
    CasterSpec,
    ChassisSpec,
    LimitsSpec,
    MastSpec,
    OdometrySpec,
    RobotSpec,
    SensorsSpec,
    WheelSpec,
)
from sim.types import Box, Cylinder, Geometry, Pose3D, Sphere
from sim.urdf_model import UrdfJoint, UrdfRobot, UrdfSensor
from sim.urdf_parser import parse_urdf
from sim.urdf_process import write_loadable_urdf
from sim.urdf_sensors import DEPTH_TYPES, LIDAR_TYPES, SensorReport, camera_spec, depth_spec, imu_spec, lidar_spec, pick
from sim.xacro_expand import expand_xacro, is_xacro_text

WHEEL_TYPES = ("continuous", "revolute")


@dataclass(frozen=True)
class LoadedRobot:
    spec: RobotSpec
    warnings: tuple[str, ...]
    source: str  # the file it came from, or "<string>"


def read_description(source: str | Path, package_path: list[Path] | None = None) -> tuple[str, str, Path]:
    """(URDF text, name for messages, folder relative paths start from) of a .urdf/.xacro file or text."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        text = expand_xacro(source, package_path=package_path) if is_xacro_text(source) else source
        return text, "<string>", Path.cwd()
    path = Path(source)
    if not path.is_file():
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read robot description {path}: no such file", "check the path")
    if path.suffix == ".xacro":
        return expand_xacro(path, package_path=package_path), str(path), path.resolve().parent
    text = path.read_text(encoding="utf-8")
    if is_xacro_text(text):
        return expand_xacro(path, package_path=package_path), str(path), path.resolve().parent
    return text, str(path), path.resolve().parent


def load_urdf_robot(source: str | Path, package_path: list[Path] | None = None) -> LoadedRobot:
    text, name, base_dir = read_description(source, package_path)
    robot = parse_urdf(text, name=name, base_dir=base_dir)
    warnings: list[str] = []
    drive = _drive(robot, warnings)
    left = [_wheel_joint(robot, j) for j in drive.left_joints]
    right = [_wheel_joint(robot, j) for j in drive.right_joints]
    poses = robot.link_poses()
    lc = np.mean([poses[j.child].position for j in left], axis=0)
    rc = np.mean([poses[j.child].position for j in right], axis=0)
    geo_radius = _wheel_radius(robot, left + right)
    radius = _choose("wheel radius", drive.wheel_radius, geo_radius, "m", warnings)
    if radius is None:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{name}: no wheel radius: the diff-drive plugin gives no "
                         "wheel_diameter/wheel_radius and the wheels have no cylinder or sphere collision",
                         "add <wheel_diameter> to the plugin or a cylinder collision to the wheel links")
    separation = _choose("wheel separation", drive.wheel_separation, float(abs(lc[1] - rc[1])), "m", warnings)
    assert separation is not None
    if separation <= 0:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{name}: left and right wheels are not apart in y",
                         "a differential drive needs its wheels on either side of base_link x")
    mid = (lc + rc) / 2
    if abs(lc[2] - rc[2]) > 1e-3:
        warnings.append(f"left and right wheel centres differ in height by {abs(lc[2] - rc[2]):.3f} m")
    # fleetnav's base_link: on the floor under the axle centre, axes as the root's (REP-103: x forward).
    root_in_base = Pose3D(-float(mid[0]), -float(mid[1]), radius - float(mid[2]))
    in_base = {link: root_in_base.compose(pose) for link, pose in poses.items()}
    report = SensorReport()
    sensors = list(robot.sensors)

    def mount(s: UrdfSensor) -> Pose3D:
        link = s.link if s.link in in_base else robot.joints[s.link].child
        return in_base[link].compose(s.pose)

    lidar_s, cam_s = pick(sensors, LIDAR_TYPES, report), pick(sensors, ("camera",), report)
    lidar = lidar_spec(lidar_s, mount(lidar_s) if lidar_s else Pose3D(), report)
    if lidar.mount is not None and abs(lidar.mount[1]) > 1e-3:
        report.warnings.append(f"lidar is {lidar.mount[1]:.3f} m off base_link x: simulated on the x axis")
    camera = camera_spec(cam_s, mount(cam_s) if cam_s else Pose3D(), report)
    odom_hz = _need("diff drive <update_rate>", drive.update_rate, OdometrySpec().rate_hz, " Hz", warnings)
    sensors_spec = SensorsSpec(lidar=lidar, camera=camera, depth=depth_spec(pick(sensors, DEPTH_TYPES, report),
                                                                             report),
                               imu=imu_spec(pick(sensors, ("imu",), report), report),
                               odometry=OdometrySpec(rate_hz=odom_hz))
    warnings += report.warnings
    wheel_link = robot.links[left[0].child]
    wheel_mass = wheel_link.inertial.mass if wheel_link.inertial else 0.0
    extent = _extent(robot, in_base, warnings)
    chassis = _chassis(robot, in_base, {j.child for j in left + right}, extent)
    total = robot.total_mass()
    wheel_links = {j.child for j in left + right}
    caster = _caster(robot, in_base, wheel_links, chassis)
    mast_x = lidar.mount[0] if lidar.mount is not None else 0.0
    spec = RobotSpec(
        name=robot.name or Path(name).stem,
        chassis=ChassisSpec(size=chassis[0], ground_clearance=max(0.0, chassis[1]),
                            # The rest of the description's mass, so total_mass is the file's total.
                            mass=max(1e-3, total - 2 * max(1e-3, wheel_mass) - caster.mass - 1e-3)),
        wheels=WheelSpec(radius=radius, width=min(_wheel_width(robot, left[0]), 0.99 * separation),
                         separation=separation, mass=max(1e-3, wheel_mass), max_torque=_torque(drive, left, warnings),
                         left_joints=tuple(j.name for j in left), right_joints=tuple(j.name for j in right)),
        caster=caster,
        mast=MastSpec(height=max(1e-3, (lidar.mount[2] if lidar.mount else 0.0) - chassis[1] - chassis[0][2]),
                      x_offset=mast_x, mass=1e-3),
        limits=_limits(drive, left, radius, separation, warnings),
        sensors=sensors_spec, extent=extent,
    )
    description = write_loadable_urdf(text, base_dir, robot.root, root_in_base, package_path)
    return LoadedRobot(spec.model_copy(update={"description": str(description)}), tuple(warnings), name)


def _caster(robot: UrdfRobot, in_base: dict[str, Pose3D], wheels: set[str],
            chassis: tuple[tuple[float, float, float], float]) -> CasterSpec:
    """The spec's caster summary: the first non-wheel link named *caster* or holding a sphere collision."""
    for link in robot.links.values():
        spheres = [c for c in link.collisions if isinstance(c.geometry, Sphere)]
        if link.name in wheels or not (spheres or "caster" in link.name.lower()):
            continue
        radius = spheres[0].geometry.radius if spheres and isinstance(spheres[0].geometry, Sphere) else 0.01
        half = chassis[0][0] / 2
        x = min(half, max(-half, in_base[link.name].x))  # the spec keeps it under the chassis
        return CasterSpec(radius=radius, x_offset=x, mass=link.inertial.mass if link.inertial and
                          link.inertial.mass > 0 else 1e-3)
    return CasterSpec(radius=0.01, x_offset=0.0, mass=1e-3)  # none (4-wheel bases): a token, never simulated


def _drive(robot: UrdfRobot, warnings: list[str]) -> DiffDriveParams:
    plugins = [p for p in robot.plugins if is_diff_drive(p)]
    if plugins:
        d = diff_drive_params(plugins[0], robot.source)
        if d.left_joints and d.right_joints:
            return d
        warnings.append(f"diff-drive plugin '{plugins[0].filename}' names no left/right joints: found by name")
    else:
        warnings.append("no diff-drive plugin (libgazebo_ros_diff_drive / gz-sim-diff-drive-system): wheels found "
                        "by joint name, separation and radius from the geometry, limits defaulted")
        d = DiffDriveParams(plugin="", left_joints=(), right_joints=())
    wheels = [j for j in robot.joints.values() if j.type in WHEEL_TYPES and "wheel" in (j.name + j.child).lower()]
    left = tuple(j.name for j in wheels if "left" in (j.name + j.child).lower())
    right = tuple(j.name for j in wheels if "right" in (j.name + j.child).lower())
    if not left or not right:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{robot.source}: no differential drive: no diff-drive plugin "
                         "and no continuous joints named left/right ...wheel",
                         f"add a diff-drive plugin naming the wheel joints; joints: {', '.join(robot.joints)}")
    return DiffDriveParams(**{**d.__dict__, "left_joints": left, "right_joints": right})


def _wheel_joint(robot: UrdfRobot, name: str) -> UrdfJoint:
    joint = robot.joints.get(name)
    if joint is None or joint.type not in WHEEL_TYPES:
        what = "is not defined" if joint is None else f"is {joint.type}, not continuous"
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{robot.source}: the diff drive's wheel joint '{name}' {what}",
                         f"joints: {', '.join(f'{j.name} ({j.type})' for j in robot.joints.values())}")
    return joint


def _wheel_radius(robot: UrdfRobot, joints: list[UrdfJoint]) -> float | None:
    radii = [c.geometry.radius for j in joints for c in robot.links[j.child].collisions
             if isinstance(c.geometry, Cylinder | Sphere)]
    return float(np.mean(radii)) if radii else None


def _wheel_width(robot: UrdfRobot, joint: UrdfJoint) -> float:
    widths = [c.geometry.length for c in robot.links[joint.child].collisions if isinstance(c.geometry, Cylinder)]
    return widths[0] if widths else 0.01


def _choose(what: str, plugin: float | None, geometry: float | None, unit: str, warnings: list[str]) -> float | None:
    """The plugin's value (what Gazebo's controller uses); the geometry's where the plugin is silent."""
    if plugin is not None and geometry is not None and abs(plugin - geometry) > 0.01 * geometry:
        warnings.append(f"{what}: the diff-drive plugin says {plugin:g} {unit}, the joints/geometry {geometry:.4g} "
                        f"{unit}: the plugin's value drives the robot (as in Gazebo)")
    if plugin is None and geometry is not None:
        warnings.append(f"{what} not in the diff-drive plugin: {geometry:.4g} {unit} from the geometry")
    return plugin if plugin is not None else geometry


def _need(what: str, got: float | None, default: float, unit: str, warnings: list[str]) -> float:
    if got is None:
        warnings.append(f"{what} not given: using {default:g}{unit}")
        return default
    return got


def _torque(d: DiffDriveParams, left: list[UrdfJoint], warnings: list[str]) -> float:
    if d.max_wheel_torque:
        return d.max_wheel_torque
    effort = left[0].limit.effort if left[0].limit else None
    return _need("max wheel torque (plugin <max_wheel_torque> or joint effort)", effort or None,
                 WheelSpec().max_torque, " N·m", warnings)


def _limits(d: DiffDriveParams, left: list[UrdfJoint], r: float, sep: float, warnings: list[str]) -> LimitsSpec:
    """Twist limits: the plugin's (Gazebo Sim), else the wheel joints' velocity limit, else defaults."""
    default = LimitsSpec()
    wheel_w = left[0].limit.velocity if left[0].limit and left[0].limit.velocity else None
    v = d.max_linear or (wheel_w * r if wheel_w else None)
    w = d.max_angular or (2 * wheel_w * r / sep if wheel_w else None)
    a = d.max_linear_accel or d.max_wheel_acceleration
    alpha = d.max_angular_accel or (2 * d.max_wheel_acceleration / sep if d.max_wheel_acceleration else None)
    return LimitsSpec(max_linear=_need("max linear speed", v, default.max_linear, " m/s", warnings),
                      max_angular=_need("max angular speed", w, default.max_angular, " rad/s", warnings),
                      max_linear_accel=_need("max linear acceleration", a, default.max_linear_accel, " m/s²", warnings),
                      max_angular_accel=_need("max angular acceleration", alpha, default.max_angular_accel,
                                              " rad/s²", warnings))


def half_extents(pose: Pose3D, g: Geometry) -> np.ndarray | None:
    """Half-size of the shape's world-axis bounding box (None for meshes and planes)."""
    rot = np.abs(pose.matrix()[:3, :3])
    if isinstance(g, Box):
        return np.asarray(rot @ (np.asarray(g.size) / 2))
    if isinstance(g, Cylinder):
        axis = rot[:, 2]
        return np.asarray(g.radius * np.sqrt(np.clip(1 - axis**2, 0, 1)) + g.length / 2 * axis)
    if isinstance(g, Sphere):
        return np.full(3, g.radius)
    return None


def _extent(robot: UrdfRobot, in_base: dict[str, Pose3D],
            warnings: list[str]) -> tuple[float, float, float, float]:
    lo, hi, meshes = np.full(3, np.inf), np.full(3, -np.inf), 0
    for link, pose in in_base.items():
        for c in robot.links[link].collisions:
            shape_pose = pose.compose(c.origin)
            h = half_extents(shape_pose, c.geometry)
            if h is None:
                meshes += 1
                continue
            centre = np.asarray(shape_pose.position)
            lo, hi = np.minimum(lo, centre - h), np.maximum(hi, centre + h)
    if meshes:
        warnings.append(f"{meshes} mesh collision(s) not counted in the footprint (planners use the primitives' "
                        "bounding box)")
    if not np.isfinite(lo).all():
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{robot.source}: no box/cylinder/sphere collision geometry",
                         "fleetnav needs primitive collisions to size the robot's footprint")
    return (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]))


def _chassis(robot: UrdfRobot, in_base: dict[str, Pose3D], wheels: set[str],
             extent: tuple[float, float, float, float]) -> tuple[tuple[float, float, float], float]:
    """(size, bottom height) of the biggest non-wheel collision shape: the spec's summary of the body."""
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for link, pose in in_base.items():
        if link in wheels:
            continue
        for c in robot.links[link].collisions:
            shape_pose = pose.compose(c.origin)
            h = half_extents(shape_pose, c.geometry)
            if h is not None and (best is None or float(np.prod(h)) > best[0]):
                best = (float(np.prod(h)), np.asarray(shape_pose.position), h)
    if best is None:
        x0, x1, y0, y1 = extent
        return (max(1e-3, x1 - x0), max(1e-3, y1 - y0), 0.01), 0.0
    _, centre, h = best
    size = (float(2 * h[0]), float(2 * h[1]), float(2 * h[2]))
    return size, float(centre[2] - h[2])


__all__ = ["LoadedRobot", "half_extents", "load_urdf_robot", "read_description"]
