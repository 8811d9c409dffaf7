"""The known map as a planar lidar sees it: the world's collision shapes sliced at the lidar height,
sampled as points with outward normals (for point-to-line scan alignment).

Boxes are sliced exactly at any orientation (plane ∩ 12 edges → convex polygon); upright cylinders and
spheres give circles. Meshes (unknown extent), tilted cylinders and the ground plane are skipped.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Collection

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from sim.types import Box, Cylinder, Pose3D, Sphere, WorldDescription

_TILT_EPS = 1e-6


def map_outline(description: WorldDescription, height: float, spacing: float = 0.02,
                exclude: Collection[str] = ()) -> tuple[np.ndarray, np.ndarray]:
    """(points (m, 2), unit outward normals (m, 2)) of every obstacle's outline at z = `height`."""
    pts: list[np.ndarray] = []
    nrm: list[np.ndarray] = []
    for model in description.obstacle_models():
        if model.name in exclude:
            continue
        for _, col, pose in model.world_collisions():
            g = col.geometry
            if isinstance(g, Box):
                poly = _box_slice(pose, g.size, height)
                if poly is not None:
                    p, n = _sample_polygon(poly, spacing)
                    pts.append(p)
                    nrm.append(n)
            elif isinstance(g, Cylinder | Sphere):
                r = _round_slice(pose, g, height)
                if r is not None:
                    p, n = _sample_circle((pose.x, pose.y), r, spacing)
                    pts.append(p)
                    nrm.append(n)
    if not pts:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.concatenate(pts), np.concatenate(nrm)


def _box_slice(pose: Pose3D, size: tuple[float, float, float], h: float) -> np.ndarray | None:
    half = 0.5 * np.asarray(size, dtype=float)
    corners = np.array(list(itertools.product(*[(-1.0, 1.0)] * 3))) * half
    m = pose.matrix()
    world = corners @ m[:3, :3].T + m[:3, 3]
    hits = []
    for i, j in itertools.combinations(range(8), 2):
        if np.count_nonzero(corners[i] != corners[j]) != 1:
            continue  # not an edge of the box
        zi, zj = world[i, 2] - h, world[j, 2] - h
        if zi * zj < 0:
            t = zi / (zi - zj)
            hits.append(world[i, :2] + t * (world[j, :2] - world[i, :2]))
    if len(hits) < 3:
        return None
    q = np.array(hits)
    try:
        hull = ConvexHull(q)
    except QhullError:
        return None
    return q[hull.vertices]  # counter-clockwise in 2-D


def _sample_polygon(poly: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    pts, nrm = [], []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        edge = b - a
        length = float(np.linalg.norm(edge))
        if length < 1e-9:
            continue
        k = max(1, math.ceil(length / spacing))
        t = (np.arange(k) + 0.5) / k
        pts.append(a + t[:, None] * edge)
        n = np.array([edge[1], -edge[0]]) / length  # CCW polygon: the right-hand normal points out
        nrm.append(np.tile(n, (k, 1)))
    return np.concatenate(pts), np.concatenate(nrm)


def _round_slice(pose: Pose3D, g: Cylinder | Sphere, h: float) -> float | None:
    dz = h - pose.z
    if isinstance(g, Sphere):
        return math.sqrt(g.radius ** 2 - dz ** 2) if abs(dz) < g.radius else None
    if abs(pose.roll) > _TILT_EPS or abs(pose.pitch) > _TILT_EPS:
        return None  # a tilted cylinder slices into an ellipse; not modelled
    return g.radius if abs(dz) <= g.length / 2 else None


def _sample_circle(centre: tuple[float, float], r: float, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    k = max(8, math.ceil(2 * math.pi * r / spacing))
    a = 2 * math.pi * np.arange(k) / k
    n = np.column_stack([np.cos(a), np.sin(a)])
    return np.asarray(centre) + r * n, n
