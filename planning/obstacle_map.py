"""ObstacleMap: a map without artificial bounds, built from what the lidar sees (or from a prior world).

It keeps obstacles as exact points (lidar returns, or the outlines of known obstacles sampled every
`point_resolution`), deduplicated on a fine lattice, plus a coarse grid (`resolution`) with per-cell
occupancy, a `seen` flag (the cell was swept by a beam or is covered by the prior map) and a distance field
for planners. The grid grows on demand (`ensure`) to cover whatever the robot needs: start, goal, margin.

Scans mark returns and clear, Nav2-obstacle-layer style, every stored point a beam passed through: a point is
contradicted when the beam whose bearing passes within `clear_lateral` of it returned beyond it (in polar form,
so clearing is exact and never erases the obstacle a beam grazed).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.spatial import cKDTree

from planning.shapes import DEFAULT_SLAB, world_footprints
from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan, Pose2D, WorldDescription

Bounds = tuple[float, float, float, float]


class ObstacleMap:
    def __init__(self, bounds: Bounds, *, resolution: float = 0.05, point_resolution: float = 0.02,
                 grow_step: float = 2.0, obstacle_max_range: float = 8.0, raytrace_max_range: float = 8.0,
                 clear_lateral: float = 0.01, clear_behind: float = 0.06) -> None:
        if not (resolution > 0 and point_resolution > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "map resolutions must be > 0")
        self.resolution, self.point_resolution, self.grow_step = resolution, point_resolution, grow_step
        self.obstacle_max_range, self.raytrace_max_range = obstacle_max_range, raytrace_max_range
        self.clear_lateral, self.clear_behind = clear_lateral, clear_behind
        self.origin = (math.floor(bounds[0] / resolution) * resolution, math.floor(bounds[1] / resolution) * resolution)
        w = max(1, math.ceil((bounds[2] - self.origin[0]) / resolution))
        h = max(1, math.ceil((bounds[3] - self.origin[1]) / resolution))
        self.seen = np.zeros((h, w), dtype=bool)
        self.occ = np.zeros((h, w), dtype=bool)
        self.points = np.zeros((0, 2))
        self.version = 0
        self._dist: tuple[int, np.ndarray] | None = None  # caches, valid while `version` is unchanged
        self._tree: tuple[int, cKDTree] | None = None

    # ---- geometry -------------------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        return self.occ.shape

    @property
    def bounds(self) -> Bounds:
        h, w = self.shape
        return (self.origin[0], self.origin[1], self.origin[0] + w * self.resolution,
                self.origin[1] + h * self.resolution)

    def cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return (np.floor((xy[:, 1] - self.origin[1]) / self.resolution).astype(np.int64),
                np.floor((xy[:, 0] - self.origin[0]) / self.resolution).astype(np.int64))

    def inside(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        h, w = self.shape
        return (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        h, w = self.shape
        return (self.origin[0] + (np.arange(w) + 0.5) * self.resolution,
                self.origin[1] + (np.arange(h) + 0.5) * self.resolution)

    def ensure(self, bounds: Bounds) -> bool:
        """Grow (never shrink) so the grid covers `bounds`, in steps of `grow_step`; True if it grew."""
        x0, y0, x1, y1 = self.bounds
        res, g = self.resolution, self.grow_step
        add_l = math.ceil(max(0.0, x0 - bounds[0]) / g) * round(g / res)
        add_b = math.ceil(max(0.0, y0 - bounds[1]) / g) * round(g / res)
        add_r = math.ceil(max(0.0, bounds[2] - x1) / g) * round(g / res)
        add_t = math.ceil(max(0.0, bounds[3] - y1) / g) * round(g / res)
        if not (add_l or add_b or add_r or add_t):
            return False
        pad = ((add_b, add_t), (add_l, add_r))
        self.seen = np.pad(self.seen, pad)
        self.occ = np.pad(self.occ, pad)
        self.origin = (self.origin[0] - add_l * res, self.origin[1] - add_b * res)
        self._changed()
        return True

    # ---- content --------------------------------------------------------------------------------------

    def add_points(self, pts: np.ndarray) -> None:
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts) == 0:
            return
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        self.ensure((float(lo[0]) - 1.0, float(lo[1]) - 1.0, float(hi[0]) + 1.0, float(hi[1]) + 1.0))
        allp = np.vstack([self.points, pts])
        keys = np.floor(allp / self.point_resolution).astype(np.int64)
        _, first = np.unique(keys[:, 0] * 4_000_003 + keys[:, 1], return_index=True)
        self.points = allp[np.sort(first)]
        self._rebuild_occ()

    def add_prior(self, description: WorldDescription, slab: tuple[float, float] = DEFAULT_SLAB) -> None:
        """Every obstacle of a known world, its outline sampled every `point_resolution`; the whole grid
        counts as seen (a prior map has no unknown space)."""
        outline: list[np.ndarray] = []
        step = self.point_resolution
        for fp in world_footprints(description, slab):
            if fp.kind == "circle":
                n = max(8, math.ceil(2 * math.pi * fp.radius / step))
                a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
                outline.append(np.column_stack([fp.centre[0] + fp.radius * np.cos(a),
                                                fp.centre[1] + fp.radius * np.sin(a)]))
            else:
                assert fp.vertices is not None
                v = np.asarray(fp.vertices, dtype=float)
                for p, q in zip(v, np.roll(v, -1, axis=0), strict=True):
                    n = max(1, math.ceil(float(np.hypot(*(q - p))) / step))
                    t = np.linspace(0.0, 1.0, n, endpoint=False)[:, None]
                    outline.append(p + t * (q - p))
        if outline:
            self.add_points(np.vstack(outline))
        self.seen[:] = True
        self._changed()

    def integrate_scan(self, scan: LidarScan, pose: Pose2D, sensor_offset: tuple[float, float] = (0.0, 0.0)) -> None:
        """Clear the points the beams passed through, mark the new returns, flag the swept cells as seen."""
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        ox = pose.x + c * sensor_offset[0] - s * sensor_offset[1]
        oy = pose.y + s * sensor_offset[0] + c * sensor_offset[1]
        rng = np.asarray(scan.ranges, dtype=float)
        ang = scan.angles() + pose.yaw
        hit = np.isfinite(rng) & (rng >= scan.range_min) & (rng <= self.obstacle_max_range)
        reach = min(scan.range_max, self.raytrace_max_range)
        self._clear_contradicted(ox, oy, pose.yaw, scan, rng, reach)
        self._mark_seen(ox, oy, ang, np.where(np.isfinite(rng), np.minimum(rng, reach), reach))
        if hit.any():
            self.add_points(np.column_stack([ox + rng[hit] * np.cos(ang[hit]), oy + rng[hit] * np.sin(ang[hit])]))
        else:
            self._changed()

    def _clear_contradicted(self, ox: float, oy: float, yaw: float, scan: LidarScan, rng: np.ndarray,
                            reach: float) -> None:
        if len(self.points) == 0:
            return
        d = self.points - [ox, oy]
        r = np.hypot(d[:, 0], d[:, 1])
        near = np.flatnonzero((r < reach) & (r > scan.range_min))
        if near.size == 0:
            return
        bearing = np.remainder(np.arctan2(d[near, 1], d[near, 0]) - yaw - scan.angle_min, 2 * math.pi)
        idx = np.rint(bearing / scan.angle_increment).astype(np.int64)
        ok = idx < rng.size
        near, idx, bearing = near[ok], idx[ok], bearing[ok]
        lateral = r[near] * np.abs(bearing - idx * scan.angle_increment)
        beam = rng[idx]
        beam = np.where(np.isfinite(beam), beam, scan.range_max)
        gone = near[(lateral <= self.clear_lateral) & (beam > r[near] + self.clear_behind)]
        if gone.size:
            keep = np.ones(len(self.points), dtype=bool)
            keep[gone] = False
            self.points = self.points[keep]
            self._rebuild_occ()

    def _mark_seen(self, ox: float, oy: float, ang: np.ndarray, extent: np.ndarray) -> None:
        t = np.arange(0.0, float(extent.max(initial=0.0)), self.resolution)
        if t.size == 0:
            return
        keep = t[None, :] <= extent[:, None]
        xs = (ox + t[None, :] * np.cos(ang)[:, None])[keep]
        ys = (oy + t[None, :] * np.sin(ang)[:, None])[keep]
        rows, cols = self.cells(np.column_stack([xs, ys]))
        ok = self.inside(rows, cols)
        self.seen[rows[ok], cols[ok]] = True

    def _rebuild_occ(self) -> None:
        self.occ[:] = False
        if len(self.points):
            rows, cols = self.cells(self.points)
            ok = self.inside(rows, cols)
            self.occ[rows[ok], cols[ok]] = True
        self._changed()

    def _changed(self) -> None:
        self.version += 1

    # ---- derived (cached per version) -----------------------------------------------------------------

    def distance_field(self) -> np.ndarray:
        """(h, w) distance from each cell centre to the nearest occupied cell centre, m (inf: none)."""
        if self._dist is not None and self._dist[0] == self.version:
            return self._dist[1]
        d = distance_transform_edt(~self.occ) * self.resolution if self.occ.any() else np.full(self.shape, np.inf)
        self._dist = (self.version, d)
        return d

    def tree(self) -> cKDTree:
        if self._tree is not None and self._tree[0] == self.version:
            return self._tree[1]
        t = cKDTree(self.points if len(self.points) else np.zeros((0, 2)))
        self._tree = (self.version, t)
        return t

    def points_near(self, x: float, y: float, radius: float) -> np.ndarray:
        if len(self.points) == 0:
            return self.points
        return self.points[self.tree().query_ball_point([x, y], radius)]

    def clearance_at(self, xy: np.ndarray) -> np.ndarray:
        """Distance from each point to the nearest obstacle point (inf: none)."""
        if len(self.points) == 0:
            return np.full(len(xy), np.inf)
        d, _ = self.tree().query(np.asarray(xy, dtype=float).reshape(-1, 2))
        return np.asarray(d)
