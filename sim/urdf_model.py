"""What a URDF file holds, as plain dataclasses (sim.urdf_parser fills them), and the queries a robot check
needs: total mass, wheel separation, link poses at given joint angles (forward kinematics over the tree), and
the lowest collision point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.inertia import Inertia
from sim.types import Box, Cylinder, Geometry, Mesh, Pose3D, Sphere

JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
_ZERO = Pose3D()


@dataclass(frozen=True, slots=True)
class UrdfInertial:
    mass: float
    origin: Pose3D  # centre of mass and principal-frame orientation, in the link frame
    inertia: Inertia


@dataclass(frozen=True, slots=True)
class UrdfShape:
    """A visual or collision element: geometry placed at `origin` in its link's frame."""

    name: str
    geometry: Geometry
    origin: Pose3D = _ZERO
    rgba: tuple[float, float, float, float] | None = None  # visuals with an inline <color> only


@dataclass(frozen=True, slots=True)
class ContactFriction:
    """PyBullet's `<contact>` extension inside a link (None where the file leaves the default)."""

    lateral: float | None = None
    rolling: float | None = None
    spinning: float | None = None


@dataclass(frozen=True, slots=True)
class UrdfLink:
    name: str
    inertial: UrdfInertial | None
    visuals: tuple[UrdfShape, ...] = ()
    collisions: tuple[UrdfShape, ...] = ()
    contact: ContactFriction | None = None
    gazebo: dict[str, str] = field(default_factory=dict)  # <gazebo reference=link> scalars: mu1, mu2, kp ...
    line: int = 0


@dataclass(frozen=True, slots=True)
class JointLimit:
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    velocity: float | None = None


@dataclass(frozen=True, slots=True)
class UrdfJoint:
    name: str
    type: str
    parent: str
    child: str
    origin: Pose3D = _ZERO  # child frame in the parent frame at zero joint position
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)  # URDF default
    limit: JointLimit | None = None
    line: int = 0


@dataclass(frozen=True, slots=True)
class UrdfPlugin:
    name: str
    filename: str
    params: tuple[tuple[str, str], ...] = ()  # (path, text); nested tags as "ros/remapping", repeats kept

    def param(self, key: str) -> str | None:
        return next((v for k, v in self.params if k == key), None)

    def params_all(self, key: str) -> list[str]:
        return [v for k, v in self.params if k == key]


@dataclass(frozen=True, slots=True)
class UrdfSensor:
    """A Gazebo `<sensor>` attached to `link`; fields a sensor type lacks are None."""

    name: str
    type: str  # ray | gpu_ray | camera | depth | imu | contact ...
    link: str
    update_rate: float | None = None
    samples: int | None = None  # ray: beams per scan
    resolution: float | None = None  # ray: Gazebo's sample multiplier (1 = one ray per sample)
    min_angle: float | None = None
    max_angle: float | None = None
    range_min: float | None = None  # ray range, or a camera's clip planes
    range_max: float | None = None
    horizontal_fov: float | None = None  # rad
    image_width: int | None = None
    image_height: int | None = None
    image_format: str | None = None
    noise_stddev: float | None = None
    plugins: tuple[UrdfPlugin, ...] = ()
    line: int = 0
    accel_noise_stddev: float | None = None  # imu: linear acceleration noise (noise_stddev is the gyro's)
    pose: Pose3D = _ZERO  # the sensor's <pose> in its link's frame

    def plugin(self) -> UrdfPlugin | None:
        return self.plugins[0] if self.plugins else None


@dataclass(frozen=True)
class UrdfRobot:
    name: str
    links: dict[str, UrdfLink]
    joints: dict[str, UrdfJoint]
    sensors: tuple[UrdfSensor, ...] = ()
    plugins: tuple[UrdfPlugin, ...] = ()  # model-level <gazebo><plugin>
    source: str = "<string>"

    @property
    def root(self) -> str:
        children = {j.child for j in self.joints.values()}
        return next(name for name in self.links if name not in children)

    def child_joints(self, link: str) -> list[UrdfJoint]:
        return [j for j in self.joints.values() if j.parent == link]

    def total_mass(self) -> float:
        return sum(link.inertial.mass for link in self.links.values() if link.inertial is not None)

    def link_poses(self, positions: dict[str, float] | None = None,
                   base: Pose3D = _ZERO) -> dict[str, Pose3D]:
        """Forward kinematics: every link frame in the frame of `base` (the root's pose), joints at
        `positions` (rad or m; 0 where absent)."""
        q = positions or {}
        if unknown := sorted(set(q) - set(self.joints)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{self.source}: no joint named {', '.join(unknown)}",
                             f"joints: {', '.join(self.joints)}")
        out = {self.root: base.matrix()}
        stack = [self.root]
        while stack:
            parent = stack.pop()
            for j in self.child_joints(parent):
                out[j.child] = out[parent] @ j.origin.matrix() @ _joint_motion(j, q.get(j.name, 0.0))
                stack.append(j.child)
        return {name: Pose3D.from_matrix(m) for name, m in out.items()}

    def wheel_separation(self, left: str = "left_wheel_joint", right: str = "right_wheel_joint") -> float:
        """Distance between the two wheel joints' origins (the wheel centres)."""
        for name in (left, right):
            if name not in self.joints:
                raise FleetError(ErrorCode.NOT_FOUND, f"{self.source}: no joint '{name}'",
                                 f"joints: {', '.join(self.joints)}")
        poses = self.link_poses()
        a, b = poses[self.joints[left].child], poses[self.joints[right].child]
        return math.dist(a.position, b.position)

    def lowest_point(self, link: str | None = None, base: Pose3D = _ZERO) -> float:
        """Lowest z of the collision geometry (of one link, or all), with the root at `base`."""
        if link is not None and link not in self.links:
            raise FleetError(ErrorCode.NOT_FOUND, f"{self.source}: no link '{link}'",
                             f"links: {', '.join(self.links)}")
        poses = self.link_poses(base=base)
        zs = [_min_z(pose.compose(shape.origin), shape.geometry)
              for name, pose in poses.items() if link in (None, name)
              for shape in self.links[name].collisions if not isinstance(shape.geometry, Mesh)]
        if not zs:
            raise FleetError(ErrorCode.NOT_FOUND, f"{self.source}: no box/cylinder/sphere collision on "
                             f"{link or 'any link'}", "lowest_point measures primitive shapes only")
        return min(zs)


def _joint_motion(joint: UrdfJoint, q: float) -> np.ndarray:
    m = np.eye(4)
    axis = np.asarray(joint.axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    if joint.type in ("revolute", "continuous"):  # Rodrigues
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        m[:3, :3] = np.eye(3) + math.sin(q) * k + (1 - math.cos(q)) * (k @ k)
    elif joint.type == "prismatic":
        m[:3, 3] = axis * q
    return m


def _min_z(pose: Pose3D, g: Geometry) -> float:
    """Centre height minus the shape's half-extent along world z (closed form per primitive)."""
    r = pose.matrix()[:3, :3]
    if isinstance(g, Box):
        half = 0.5 * float(np.abs(r[2, :]) @ np.asarray(g.size))
    elif isinstance(g, Cylinder):
        az = abs(float(r[2, 2]))  # world-z component of the cylinder axis
        half = g.radius * math.sqrt(max(0.0, 1.0 - az * az)) + 0.5 * g.length * az
    elif isinstance(g, Sphere):
        half = g.radius
    else:
        raise FleetError(ErrorCode.UNSUPPORTED, f"no extent for {g.kind} geometry")
    return pose.z - half
