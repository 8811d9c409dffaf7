"""Ground removal for 3-D clouds (depth camera): a RANSAC plane fit, or a plain height threshold.

RANSAC only samples planes within `max_tilt` of horizontal, so a large wall facing the camera cannot win
over a smaller floor; the winning plane is refined by least squares on its inliers.
"""

from __future__ import annotations

import math

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.perception.types import GroundPlane


def _cloud(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"ground removal needs (n, 3) points, got {p.shape}",
                         "pass depth_to_points(image)")
    return p


def ground_by_height(points: np.ndarray, ground_z: float = 0.0, tolerance: float = 0.05) -> GroundPlane:
    """Points within `tolerance` of the plane z = ground_z are ground (a known, flat floor)."""
    p = _cloud(points)
    return GroundPlane((0.0, 0.0, 1.0), -ground_z, np.abs(p[:, 2] - ground_z) <= tolerance)


def fit_ground_plane(points: np.ndarray, *, threshold: float = 0.03, iterations: int = 200,
                     max_tilt_deg: float = 20.0, rng: np.random.Generator | None = None) -> GroundPlane:
    """RANSAC: the near-horizontal plane with most points within `threshold`, refined on its inliers.

    Pass the world's generator as `rng` so runs repeat; without one a fixed seed is used."""
    p = _cloud(points)
    if len(p) < 3:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"need ≥ 3 points to fit a plane, got {len(p)}", "")
    gen = rng if rng is not None else np.random.default_rng(0)
    cos_tilt = math.cos(math.radians(max_tilt_deg))
    best: np.ndarray | None = None
    best_count = 0
    for _ in range(iterations):
        a, b, c = p[gen.choice(len(p), 3, replace=False)]
        n = np.cross(b - a, c - a)
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            continue
        n = n / norm * (1.0 if n[2] >= 0 else -1.0)
        if n[2] < cos_tilt:
            continue
        inl = np.abs((p - a) @ n) <= threshold
        count = int(inl.sum())
        if count > best_count:
            best, best_count = inl, count
    if best is None:
        raise FleetError(ErrorCode.NOT_FOUND, "no near-horizontal plane in the cloud",
                         f"is the floor in view? raise max_tilt_deg ({max_tilt_deg}) or iterations")
    normal, d = _refine(p[best])
    inliers = np.abs(p @ normal + d) <= threshold
    return GroundPlane((float(normal[0]), float(normal[1]), float(normal[2])), float(d), inliers)


def _refine(q: np.ndarray) -> tuple[np.ndarray, float]:
    """Total least squares plane through `q`: the normal is the smallest principal axis."""
    centroid = q.mean(axis=0)
    _, _, vt = np.linalg.svd(q - centroid, full_matrices=False)
    n = vt[-1] * (1.0 if vt[-1][2] >= 0 else -1.0)
    return n, -float(n @ centroid)


def remove_ground(points: np.ndarray, plane: GroundPlane, min_height: float = 0.0) -> np.ndarray:
    """The points that are not ground and lie at least `min_height` above the plane (`plane` must have
    been fitted on these same points: its inlier mask indexes them)."""
    p = _cloud(points)
    height = p @ np.asarray(plane.normal) + plane.d
    return p[~plane.inliers & (height >= min_height)]
