"""Area coverage by Lloyd's algorithm (Cortes et al. 2004): each robot moves to the centroid of its Voronoi
cell within the polygon, which descends the locational cost H = Σ_q |q − p_nearest(q)|² dA.

The polygon is sampled on a grid (only points in free space count); each tick the sample points are
assigned to their nearest robot (a k-d tree), the cell centroids come from one bincount, and u_i =
k (centroid_i − p_i). Outcome: the Lloyd cost H (m⁴), coverage % (area within `sensing_radius` of a robot)
and the largest distance from a robot to its centroid (0 at a centroidal Voronoi configuration).
"""

from __future__ import annotations

import numpy as np
from pydantic import Field, field_validator
from scipy.spatial import cKDTree
from shapely import Polygon, contains_xy

from fleet.swarm.registry import register_behaviour
from fleet.swarm.types import BehaviourConfig, SwarmState
from sim.errors import ErrorCode, FleetError


class CoverageConfig(BehaviourConfig):
    type: str = "coverage"
    polygon: list[tuple[float, float]] = Field(description="the area to cover, ≥ 3 vertices (x, y)")
    resolution: float = Field(0.2, gt=0, description="sample spacing, m")
    gain: float = Field(0.8, gt=0, description="1/s")
    sensing_radius: float = Field(2.0, gt=0, description="what a robot covers, for coverage %, m")
    tolerance: float = Field(0.15, gt=0, description="converged when every robot is this close to its centroid, m")

    @field_validator("polygon")
    @classmethod
    def _valid(cls, v: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if len(v) < 3 or not Polygon(v).is_valid or Polygon(v).area <= 0:
            raise ValueError("polygon needs ≥ 3 vertices enclosing a non-zero area without self-intersections")
        return v


@register_behaviour("coverage", CoverageConfig)
class LloydCoverage:
    name = "coverage"
    separates_itself = True  # its own law keeps the robots apart: avoidance only against outsiders

    def __init__(self, *, polygon: list[tuple[float, float]], resolution: float = 0.2, gain: float = 0.8,
                 sensing_radius: float = 2.0, tolerance: float = 0.15) -> None:
        self.polygon = Polygon(polygon)
        self.res, self.gain, self.sensing, self.tol = resolution, gain, sensing_radius, tolerance
        self.points = self._sample(self.polygon, resolution)
        self.cell_area = resolution * resolution
        self._centroids = np.zeros((0, 2))

    @staticmethod
    def _sample(poly: Polygon, res: float) -> np.ndarray:
        x0, y0, x1, y1 = poly.bounds
        xs, ys = np.meshgrid(np.arange(x0 + res / 2, x1, res), np.arange(y0 + res / 2, y1, res))
        pts = np.column_stack([xs.ravel(), ys.ravel()])
        return np.asarray(pts[contains_xy(poly, pts[:, 0], pts[:, 1])])

    def restrict(self, free: np.ndarray) -> None:
        """Keep only sample points in free space (`free`: bool per point), e.g. off the shelves."""
        self.points = self.points[free]
        if not len(self.points):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "the coverage polygon holds no free space",
                             "draw the polygon over open floor")

    def start(self, state: SwarmState) -> None:
        pass

    def _cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        dist, owner = cKDTree(xy).query(self.points)
        n = len(xy)
        mass = np.bincount(owner, minlength=n).astype(float)
        cx = np.bincount(owner, self.points[:, 0], minlength=n)
        cy = np.bincount(owner, self.points[:, 1], minlength=n)
        cent = np.where(mass[:, None] > 0, np.column_stack([cx, cy]) / np.maximum(mass, 1)[:, None], xy)
        return cent, dist, mass

    def velocities(self, state: SwarmState) -> np.ndarray:
        cent, _, _ = self._cells(state.xy)
        self._centroids = cent
        return np.asarray(self.gain * (cent - state.xy))

    def metrics(self, state: SwarmState) -> dict[str, float]:
        cent, dist, _ = self._cells(state.xy)
        return {"lloyd_cost": float((dist**2).sum() * self.cell_area),
                "coverage_pct": float(100.0 * (dist <= self.sensing).mean()),
                "centroid_error_m": float(np.hypot(*(cent - state.xy).T).max())}

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        return metrics["centroid_error_m"] <= self.tol
