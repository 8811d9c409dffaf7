"""Exact footprint-vs-world checks with python-fcl, independent of any grid.

The world's collision shapes become fcl primitives (boxes, cylinders, spheres; meshes as their bounding
box) in their true 3D poses; the robot is its footprint extruded over the height slab, as a cylinder
(radius) or a convex prism (polygon). Only obstacles reaching into the slab are kept, as in rasterize.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import fcl
import numpy as np

from planning.shapes import DEFAULT_SLAB, collision_footprint, local_box
from planning.types import Polygon
from sim.errors import ErrorCode, FleetError
from sim.types import Box, Cylinder, Mesh, Pose2D, Sphere, WorldDescription

Footprint = float | Polygon  # a radius (m) or a polygon in the robot frame


class FclWorld:
    """The static obstacles of a WorldDescription as an fcl broadphase manager."""

    def __init__(self, description: WorldDescription, *, slab: tuple[float, float] = DEFAULT_SLAB,
                 ignore_models: Sequence[str] = ()) -> None:
        self.slab = slab
        self._objects: list[fcl.CollisionObject] = []
        self._names: list[str] = []
        for model in description.models:
            if model.name in ignore_models:
                continue
            for _, col, wp in model.world_collisions():
                if collision_footprint(model.name, col, wp, slab) is None:
                    continue  # plane, or entirely above/below the robot
                obj = _fcl_object(col.geometry, wp.matrix())
                if obj is not None:
                    self._objects.append(obj)
                    self._names.append(model.name)
        self._manager = fcl.DynamicAABBTreeCollisionManager()
        if self._objects:
            self._manager.registerObjects(self._objects)
        self._manager.setup()
        self._robot_cache: dict[object, tuple[fcl.CollisionGeometry, float]] = {}

    def __len__(self) -> int:
        return len(self._objects)

    def footprint_collides(self, pose: Pose2D, footprint: Footprint) -> bool:
        if not self._objects:
            return False
        robot = self._robot(pose, footprint)
        data = fcl.CollisionData(request=fcl.CollisionRequest())
        self._manager.collide(robot, data, fcl.defaultCollisionCallback)
        return bool(data.result.is_collision)

    def min_distance(self, pose: Pose2D, footprint: Footprint) -> float:
        """Distance between the footprint and the nearest obstacle, m (0 when they touch; inf if none)."""
        if not self._objects:
            return math.inf
        robot = self._robot(pose, footprint)
        data = fcl.DistanceData()
        self._manager.distance(robot, data, fcl.defaultDistanceCallback)
        return max(float(data.result.min_distance), 0.0)

    def colliding_models(self, pose: Pose2D, footprint: Footprint) -> list[str]:
        robot = self._robot(pose, footprint)
        hits = []
        for obj, name in zip(self._objects, self._names, strict=True):
            if fcl.collide(robot, obj, fcl.CollisionRequest(), fcl.CollisionResult()) > 0:
                hits.append(name)
        return sorted(set(hits))

    def path_min_distance(self, path: np.ndarray, footprint: Footprint, step: float = 0.02) -> float:
        """Smallest min_distance along a polyline, sampled every `step` metres (yaw = segment heading)."""
        best = math.inf
        for pose in sample_path(path, step):
            best = min(best, self.min_distance(pose, footprint))
            if best == 0.0:
                break
        return best

    def _robot(self, pose: Pose2D, footprint: Footprint) -> fcl.CollisionObject:
        key = footprint if isinstance(footprint, float | int) else tuple(map(tuple, footprint))
        cached = self._robot_cache.get(key)
        if cached is None:
            cached = self._robot_geometry(footprint)
            self._robot_cache[key] = cached
        geom, z = cached
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return fcl.CollisionObject(geom, fcl.Transform(rot, np.array([pose.x, pose.y, z])))

    def _robot_geometry(self, footprint: Footprint) -> tuple[fcl.CollisionGeometry, float]:
        """The robot's geometry and the height of its frame origin (fcl cylinders are centred)."""
        z0, z1 = self.slab
        if isinstance(footprint, float | int):
            if footprint <= 0:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"footprint radius must be > 0, got {footprint}",
                                 "pass RobotSpec.footprint_radius or a polygon")
            return fcl.Cylinder(float(footprint), z1 - z0), 0.5 * (z0 + z1)
        poly = np.asarray(footprint, dtype=float)
        if poly.ndim != 2 or poly.shape[0] < 3 or poly.shape[1] != 2:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"footprint polygon must be (n≥3, 2), got {poly.shape}",
                             "pass [(x, y), ...] in the robot frame, e.g. RobotSpec.footprint")
        return _prism(poly, z0, z1), 0.0


def sample_path(path: np.ndarray, step: float) -> list[Pose2D]:
    """Poses every `step` m along a polyline (both ends included), heading along each segment."""
    pts = np.asarray(path, dtype=float)
    out: list[Pose2D] = []
    for a, b in itertools.pairwise(pts):
        d = b - a
        n = max(math.ceil(float(np.hypot(*d)) / step), 1)
        yaw = math.atan2(d[1], d[0])
        out += [Pose2D(float(a[0] + d[0] * k / n), float(a[1] + d[1] * k / n), yaw) for k in range(n)]
    last = pts[-1]
    out.append(Pose2D(float(last[0]), float(last[1]), out[-1].yaw if out else 0.0))
    return out


def _prism(poly: np.ndarray, z0: float, z1: float) -> fcl.Convex:
    if _signed_area(poly) < 0:
        poly = poly[::-1]
    n = len(poly)
    verts = np.vstack([np.column_stack([poly, np.full(n, z0)]), np.column_stack([poly, np.full(n, z1)])])
    faces = [n, *range(n - 1, -1, -1), n, *range(n, 2 * n)]
    for i in range(n):
        j = (i + 1) % n
        faces += [4, i, j, n + j, n + i]
    return fcl.Convex(verts, n + 2, np.asarray(faces, dtype=np.int64))


def _signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _fcl_object(g: object, m: np.ndarray) -> fcl.CollisionObject | None:
    rot, t = m[:3, :3], m[:3, 3]
    if isinstance(g, Box | Mesh):
        lo, hi = local_box(g)
        size, centre = hi - lo, 0.5 * (lo + hi)
        return fcl.CollisionObject(fcl.Box(*map(float, size)), fcl.Transform(rot, t + rot @ centre))
    if isinstance(g, Cylinder):
        return fcl.CollisionObject(fcl.Cylinder(g.radius, g.length), fcl.Transform(rot, t))
    if isinstance(g, Sphere):
        return fcl.CollisionObject(fcl.Sphere(g.radius), fcl.Transform(rot, t))
    return None
