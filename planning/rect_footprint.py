"""The robot's real rectangular footprint in SE(2): exact distances to obstacle points at any pose.

A point obstacle (a lidar return, or a sample of a known obstacle's outline every centimetre) is at
distance hypot(max(|x'|−a, 0), max(|y'|−b, 0)) from a rectangle of half-sizes (a, b), with (x', y') the point
in the rectangle's frame: no grid, no circumscribed circle, so the robot takes any gap its rectangle plus the
safety margin fits through.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from sim.errors import ErrorCode, FleetError


@dataclass(frozen=True, slots=True)
class RectFootprint:
    """An axis-aligned rectangle in base_link: `length` along x, `width` along y, centred at (x_offset, 0)."""

    length: float
    width: float
    x_offset: float = 0.0

    def __post_init__(self) -> None:
        if not (self.length > 0 and self.width > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"footprint must have positive size, got "
                             f"{self.length} × {self.width} m", "give length and width in metres")

    @classmethod
    def from_polygon(cls, polygon: Sequence[tuple[float, float]]) -> RectFootprint:
        """The bounding rectangle of a base_link footprint polygon (exact for the rectangles robots declare)."""
        pts = np.asarray(polygon, dtype=float)
        (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
        if abs(y0 + y1) > 1e-6:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "footprint must be symmetric about the x axis",
                             f"got y from {y0} to {y1}")
        return cls(float(x1 - x0), float(y1 - y0), float((x0 + x1) / 2))

    @property
    def half(self) -> tuple[float, float]:
        return self.length / 2, self.width / 2

    @property
    def inscribed(self) -> float:
        """Distance from the rectangle's centre to its nearest side: no footprint fits closer to a point."""
        return min(self.half)

    @property
    def circumscribed(self) -> float:
        """Distance from base_link to the farthest corner."""
        return math.hypot(abs(self.x_offset) + self.length / 2, self.width / 2)

    def describe(self, margin: float) -> str:
        return f"footprint {self.length:.3f} × {self.width:.3f} m + safety margin {margin:.3f} m"

    def distances(self, poses: npt.ArrayLike, points: np.ndarray) -> np.ndarray:
        """(P,) distance from the footprint at each pose (x, y, yaw) to the nearest of `points` (M, 2);
        0 when a point is inside, inf when there are no points."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        if len(points) == 0:
            return np.full(len(poses), np.inf)
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        cx = poses[:, 0] + self.x_offset * c  # rectangle centres
        cy = poses[:, 1] + self.x_offset * s
        dx = points[None, :, 0] - cx[:, None]
        dy = points[None, :, 1] - cy[:, None]
        lx = np.abs(dx * c[:, None] + dy * s[:, None]) - self.length / 2
        ly = np.abs(-dx * s[:, None] + dy * c[:, None]) - self.width / 2
        d = np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0))
        return np.asarray(d.min(axis=1))

    def distances_near(self, poses: np.ndarray, tree: cKDTree, points: np.ndarray, reach: float) -> np.ndarray:
        """Like `distances`, but each pose is tested only against the points within `reach` of its rectangle's
        centre (KD-tree pairs): inf where there are none. Exact when reach ≥ circumscribed + the distance
        that matters."""
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        out = np.full(len(poses), np.inf)
        if len(points) == 0 or len(poses) == 0:
            return out
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        cx, cy = poses[:, 0] + self.x_offset * c, poses[:, 1] + self.x_offset * s
        lists = tree.query_ball_point(np.column_stack([cx, cy]), reach)
        counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        if counts.sum() == 0:
            return out
        pose_idx = np.repeat(np.arange(len(poses)), counts)
        pt_idx = np.fromiter(itertools.chain.from_iterable(lists), dtype=np.int64, count=int(counts.sum()))
        dx = points[pt_idx, 0] - cx[pose_idx]
        dy = points[pt_idx, 1] - cy[pose_idx]
        cc, ss = c[pose_idx], s[pose_idx]
        lx = np.abs(dx * cc + dy * ss) - self.length / 2
        ly = np.abs(-dx * ss + dy * cc) - self.width / 2
        np.minimum.at(out, pose_idx, np.hypot(np.maximum(lx, 0.0), np.maximum(ly, 0.0)))
        return out

    def corners(self, pose: tuple[float, float, float]) -> np.ndarray:
        """(4, 2) world corners at `pose`, CCW."""
        a, b = self.half
        local = np.array([[a, b], [-a, b], [-a, -b], [a, -b]]) + np.array([self.x_offset, 0.0])
        c, s = math.cos(pose[2]), math.sin(pose[2])
        return local @ np.array([[c, s], [-s, c]]) + [pose[0], pose[1]]
