"""Value types of the sim package: poses, world descriptions (what an SDF file holds), sensor readings.

World descriptions are plain frozen dataclasses so planners can rasterise them and writers can save them
without touching PyBullet. Sensor readings carry sim time (`stamp`, seconds) and numpy arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.transforms import matrix_to_rpy, rpy_to_matrix, rpy_to_quat

Fidelity = Literal["dynamic", "kinematic"]


def _check_finite(name: str, *values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{name} must be finite, got {values}",
                         "pass real numbers (no NaN or inf)")


@dataclass(frozen=True, slots=True)
class Pose2D:
    """A planar pose in the map frame: x, y (m), yaw (rad, CCW from +x)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        _check_finite("pose", self.x, self.y, self.yaw)

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.yaw)

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)


@dataclass(frozen=True, slots=True)
class Pose3D:
    """A 3D pose: position (m) and fixed-axis roll-pitch-yaw (rad), as SDF writes it."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        _check_finite("pose", self.x, self.y, self.z, self.roll, self.pitch, self.yaw)

    @property
    def position(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)

    @property
    def quaternion(self) -> tuple[float, float, float, float]:
        return rpy_to_quat(self.roll, self.pitch, self.yaw)

    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = rpy_to_matrix(self.roll, self.pitch, self.yaw)
        m[:3, 3] = (self.x, self.y, self.z)
        return m

    @staticmethod
    def from_matrix(m: np.ndarray) -> Pose3D:
        r, p, y = matrix_to_rpy(m[:3, :3])
        return Pose3D(float(m[0, 3]), float(m[1, 3]), float(m[2, 3]), r, p, y)

    def compose(self, child: Pose3D) -> Pose3D:
        """self ⊕ child: child expressed in self's frame, returned in self's parent frame."""
        return Pose3D.from_matrix(self.matrix() @ child.matrix())

    def to_2d(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def sdf(self) -> str:
        return " ".join(f"{v:.6g}" for v in (self.x, self.y, self.z, self.roll, self.pitch, self.yaw))


# ---- geometry ---------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Box:
    size: tuple[float, float, float]
    kind: Literal["box"] = "box"


@dataclass(frozen=True, slots=True)
class Cylinder:
    radius: float
    length: float
    kind: Literal["cylinder"] = "cylinder"


@dataclass(frozen=True, slots=True)
class Sphere:
    radius: float
    kind: Literal["sphere"] = "sphere"


@dataclass(frozen=True, slots=True)
class Plane:
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    size: tuple[float, float] = (100.0, 100.0)
    kind: Literal["plane"] = "plane"


@dataclass(frozen=True, slots=True)
class Mesh:
    uri: str  # as written in the file
    path: str  # resolved absolute path on disk
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    kind: Literal["mesh"] = "mesh"


Geometry = Box | Cylinder | Sphere | Plane | Mesh


@dataclass(frozen=True, slots=True)
class Collision:
    name: str
    geometry: Geometry
    pose: Pose3D = Pose3D()  # relative to its link
    friction: float | None = None


@dataclass(frozen=True, slots=True)
class Visual:
    name: str
    geometry: Geometry
    pose: Pose3D = Pose3D()  # relative to its link
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    material: str | None = None  # e.g. a Gazebo script material name such as Gazebo/Wood


@dataclass(frozen=True, slots=True)
class Link:
    name: str
    pose: Pose3D = Pose3D()  # relative to its model
    mass: float = 0.0
    inertia: tuple[float, float, float, float, float, float] = (0, 0, 0, 0, 0, 0)  # ixx ixy ixz iyy iyz izz
    collisions: tuple[Collision, ...] = ()
    visuals: tuple[Visual, ...] = ()


@dataclass(frozen=True, slots=True)
class ModelDescription:
    """A model of the world, nested models already flattened into links with composed poses."""

    name: str
    pose: Pose3D = Pose3D()  # in the world frame
    static: bool = True
    links: tuple[Link, ...] = ()
    source: str = ""  # the include URI or file it came from, if any

    def world_collisions(self) -> list[tuple[Link, Collision, Pose3D]]:
        """Each collision with its pose in the world frame."""
        out = []
        for link in self.links:
            lp = self.pose.compose(link.pose)
            for c in link.collisions:
                out.append((link, c, lp.compose(c.pose)))
        return out


@dataclass(frozen=True, slots=True)
class Light:
    name: str
    type: str  # directional | point | spot
    pose: Pose3D = Pose3D()
    diffuse: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    cast_shadows: bool = True
    direction: tuple[float, float, float] | None = None


@dataclass(frozen=True, slots=True)
class SpawnPoint:
    name: str
    pose: Pose2D


@dataclass(frozen=True, slots=True)
class PhysicsSettings:
    step_size: float = 0.01  # s
    real_time_factor: float = 1.0
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)


@dataclass(frozen=True, slots=True)
class WorldDescription:
    """Everything a world file holds that fleetnav uses; `unsupported` lists elements it did not use."""

    name: str
    models: tuple[ModelDescription, ...] = ()
    lights: tuple[Light, ...] = ()
    spawn_points: tuple[SpawnPoint, ...] = ()
    physics: PhysicsSettings = PhysicsSettings()
    ground_material: str | None = None  # texture/material of the ground plane, if any
    unsupported: tuple[str, ...] = ()
    source: str = ""
    sdf_version: str = "1.9"

    def obstacle_models(self) -> list[ModelDescription]:
        """Models with at least one non-plane collision (the ground plane is not an obstacle)."""
        return [m for m in self.models
                if any(c.geometry.kind != "plane" for _, c, _ in m.world_collisions())]

    def bounds(self, margin: float = 0.0) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of all non-plane collision geometry (axis-aligned box of rotated shapes)."""
        pts: list[np.ndarray] = []
        for m in self.models:
            for _, c, wp in m.world_collisions():
                half = _half_extents(c.geometry)
                if half is None:
                    continue
                corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
                pts.append((wp.matrix()[:3, :3] @ corners.T).T[:, :2] + (wp.x, wp.y))
        if not pts:
            return (-5.0 - margin, -5.0 - margin, 5.0 + margin, 5.0 + margin)
        allp = np.vstack(pts)
        lo, hi = allp.min(axis=0), allp.max(axis=0)
        return (float(lo[0]) - margin, float(lo[1]) - margin, float(hi[0]) + margin, float(hi[1]) + margin)


def _half_extents(g: Geometry) -> np.ndarray | None:
    if isinstance(g, Box):
        return np.asarray(g.size, dtype=float) / 2
    if isinstance(g, Cylinder):
        return np.array([g.radius, g.radius, g.length / 2])
    if isinstance(g, Sphere):
        return np.array([g.radius] * 3)
    if isinstance(g, Mesh):
        return np.asarray(g.scale, dtype=float) / 2  # unknown extent: a nominal unit mesh
    return None


# ---- sensor readings ----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class LidarScan:
    """A planar scan in the lidar frame (REP-117: ranges outside [range_min, range_max] mean no return,
    reported as +inf)."""

    robot: str
    stamp: float
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray  # float64 (n,)
    hit_bodies: np.ndarray | None = None  # ground truth: PyBullet uid each beam hit (-1 none); see World.body_label

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size)

    def points(self) -> np.ndarray:
        """Valid returns as (k, 2) points in the lidar frame."""
        ok = np.isfinite(self.ranges)
        a = self.angles()[ok]
        r = self.ranges[ok]
        return np.column_stack([r * np.cos(a), r * np.sin(a)])


@dataclass(frozen=True, slots=True)
class ImuReading:
    robot: str
    stamp: float
    linear_acceleration: tuple[float, float, float]  # m/s², body frame, includes gravity reaction (+z up)
    angular_velocity: tuple[float, float, float]  # rad/s, body frame
    orientation: tuple[float, float, float, float]  # x y z w (ground truth + noise)


@dataclass(frozen=True, slots=True)
class OdometryReading:
    """Wheel odometry: encoder-integrated pose in the odom frame, drifting like a real robot's."""

    robot: str
    stamp: float
    pose: Pose2D
    linear: float  # m/s
    angular: float  # rad/s
    left_wheel: float  # accumulated wheel angle, rad
    right_wheel: float


@dataclass(frozen=True, slots=True)
class CameraImage:
    robot: str
    stamp: float
    width: int
    height: int
    fov_deg: float
    rgb: np.ndarray | None  # (h, w, 3) uint8
    depth: np.ndarray | None  # (h, w) float32 metres, +inf outside [near, far]
    segmentation: np.ndarray | None  # (h, w) int32 PyBullet body/link mask
    camera_pose: Pose3D  # the camera link pose in the world (x forward, z up), not the optical frame
    near: float
    far: float

    @property
    def intrinsics(self) -> tuple[float, float, float, float]:
        """(fx, fy, cx, cy) in pixels; `fov_deg` is the horizontal FOV (Gazebo's horizontal_fov), pixels square.

        The principal point follows PyBullet's TinyRenderer, which samples each pixel at its corner: rendered
        pixel (i, j) shows ideal pixel (i − ½, j + ½), measured in tests/sim/perception (docs/perception.md)."""
        fx = 0.5 * self.width / math.tan(math.radians(self.fov_deg) / 2)
        return (fx, fx, self.width / 2, self.height / 2 - 1)

    @property
    def vertical_fov_deg(self) -> float:
        return math.degrees(2 * math.atan(math.tan(math.radians(self.fov_deg) / 2) * self.height / self.width))


@dataclass(frozen=True, slots=True)
class Contact:
    other: str  # model (or robot) name
    position: tuple[float, float, float]
    normal_force: float


@dataclass(frozen=True, slots=True)
class ContactReading:
    robot: str
    stamp: float
    contacts: tuple[Contact, ...] = field(default_factory=tuple)

    @property
    def bumped(self) -> bool:
        return bool(self.contacts)
