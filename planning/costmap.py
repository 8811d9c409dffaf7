"""LayeredCostmap: static layer + obstacle layer (lidar) + keep-out zones, inflated like nav2's costmap_2d.

Layers are boolean masks; the combined lethal mask feeds one Euclidean distance transform, from which
the inflation costs, the free mask and clearance queries all come. Recomputed lazily after a change.

Why `padding`: the robot centre may be anywhere inside a cell, and an obstacle anywhere inside a lethal
cell. A cell counts as free only when its centre is more than robot_radius + padding from every lethal
cell centre; padding = √2·resolution (the default) guarantees that every point of every free cell is at
least robot_radius from every obstacle the rasteriser saw. padding = 0 is nav2's (looser) behaviour.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from scipy.ndimage import distance_transform_edt, map_coordinates

from planning.grid import OccupancyGrid
from planning.rasterize import polygon_mask, rasterize_world
from planning.shapes import DEFAULT_SLAB
from planning.types import INSCRIBED, LETHAL, UNKNOWN, Polygon
from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan, Pose2D, WorldDescription

_VERSIONS = itertools.count(1)  # shared, so a version never repeats even when an id() is reused


class LayeredCostmap:
    """A costmap over a static OccupancyGrid. Implements planning.types.Costmap."""

    def __init__(self, static: OccupancyGrid, *, robot_radius: float, padding: float | None = None,
                 inflation_radius: float | None = None, cost_scaling_factor: float = 3.0,
                 allow_unknown: bool = False, occupied_threshold: int = 65,
                 obstacle_max_range: float = 5.0, raytrace_max_range: float = 6.0,
                 sensor_offset: tuple[float, float] = (0.0, 0.0)) -> None:
        if not robot_radius >= 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot_radius must be ≥ 0, got {robot_radius}",
                             "use RobotSpec.footprint_radius")
        self.grid = static.copy()
        self._robot_radius = float(robot_radius)
        self.padding = math.sqrt(2.0) * static.resolution if padding is None else float(padding)
        self.inscribed = self._robot_radius + self.padding  # centre distance at and below which: collision
        self.inflation_radius = self.inscribed + 0.4 if inflation_radius is None else float(inflation_radius)
        self.cost_scaling_factor = float(cost_scaling_factor)
        self.allow_unknown = allow_unknown
        self.obstacle_max_range = obstacle_max_range
        self.raytrace_max_range = raytrace_max_range
        self.sensor_offset = sensor_offset
        self._static = static.occupied(occupied_threshold)
        self._unknown = static.unknown()
        self._marked = np.zeros_like(self._static)
        self._keepout = np.zeros_like(self._static)
        self.keepouts: list[list[tuple[float, float]]] = []
        self.version = 0  # new on every change, and unique across costmaps, so users can cache by it
        self._refresh()

    @classmethod
    def from_world(cls, description: WorldDescription, *, robot_radius: float, resolution: float = 0.05,
                   slab: tuple[float, float] = DEFAULT_SLAB, bounds: tuple[float, float, float, float] | None = None,
                   margin: float = 0.5, **kwargs: float | bool | tuple[float, float]) -> LayeredCostmap:
        grid = rasterize_world(description, resolution=resolution, slab=slab, bounds=bounds, margin=margin)
        return cls(grid, robot_radius=robot_radius, **kwargs)  # type: ignore[arg-type]

    # ---- Costmap protocol: geometry -------------------------------------------------------------------

    @property
    def resolution(self) -> float:
        return self.grid.resolution

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        return self.grid.bounds

    @property
    def robot_radius(self) -> float:
        return self._robot_radius

    @property
    def costs(self) -> np.ndarray:
        return self._costs

    @property
    def free_mask(self) -> np.ndarray:
        """bool (height, width): cells where the robot centre may be."""
        return self._free

    @property
    def lethal_mask(self) -> np.ndarray:
        return self._lethal

    @property
    def keepout_mask(self) -> np.ndarray:
        return self._keepout

    @property
    def distance_field(self) -> np.ndarray:
        """Distance from each cell centre to the nearest lethal cell centre, m (inf if none)."""
        return self._dist

    # ---- queries --------------------------------------------------------------------------------------

    def is_free(self, x: float, y: float) -> bool:
        r, c = self.grid.world_to_cell(x, y)
        return self.grid.in_bounds(r, c) and bool(self._free[r, c])

    def cost_at(self, x: float, y: float) -> int:
        r, c = self.grid.world_to_cell(x, y)
        return int(self._costs[r, c]) if self.grid.in_bounds(r, c) else LETHAL

    def clearance(self, x: float, y: float) -> float:
        return float(self.clearance_many(np.array([[x, y]]))[0])

    def is_free_many(self, xy: np.ndarray) -> np.ndarray:
        rows, cols = self.grid.world_to_cells(xy)
        ok = self.grid.in_bounds_many(rows, cols)
        out = np.zeros(rows.shape, dtype=bool)
        out[ok] = self._free[rows[ok], cols[ok]]
        return out

    def cost_many(self, xy: np.ndarray) -> np.ndarray:
        rows, cols = self.grid.world_to_cells(xy)
        ok = self.grid.in_bounds_many(rows, cols)
        out = np.full(rows.shape, LETHAL, dtype=np.uint8)
        out[ok] = self._costs[rows[ok], cols[ok]]
        return out

    def clearance_many(self, xy: np.ndarray) -> np.ndarray:
        """Bilinear interpolation of (centre distance − half a cell): distance to the lethal cells' edges,
        accurate to about half a cell. 0 outside the map or inside a lethal cell."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        res = self.grid.resolution
        fr = (xy[:, 1] - self.grid.origin[1]) / res - 0.5
        fc = (xy[:, 0] - self.grid.origin[0]) / res - 0.5
        out = map_coordinates(self._surface, [fr, fc], order=1, mode="nearest")
        rows, cols = self.grid.world_to_cells(xy)
        ok = self.grid.in_bounds_many(rows, cols)
        out[~ok] = 0.0
        out[ok & self._lethal[np.clip(rows, 0, self.grid.height - 1), np.clip(cols, 0, self.grid.width - 1)]] = 0.0
        return out

    def segment_free(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        return bool(self.is_free_many(segment_cells_points(self.grid, a, b)).all())

    # ---- layers ---------------------------------------------------------------------------------------

    def update_from_scan(self, scan: LidarScan, pose: Pose2D) -> None:
        """Raytrace-clear the obstacle layer along every beam, then mark the returns (nav2 ObstacleLayer)."""
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        ox = pose.x + c * self.sensor_offset[0] - s * self.sensor_offset[1]
        oy = pose.y + s * self.sensor_offset[0] + c * self.sensor_offset[1]
        ang = scan.angles() + pose.yaw
        rng = np.asarray(scan.ranges, dtype=float)
        hit = np.isfinite(rng) & (rng >= scan.range_min)
        # Clearing: up to the hit (stopping half a cell short) or, for no return, to the max range.
        extent = np.where(hit, rng - 0.5 * self.resolution, min(scan.range_max, self.raytrace_max_range))
        extent = np.minimum(extent, self.raytrace_max_range)
        steps = np.arange(0.0, float(extent.max(initial=0.0)), 0.5 * self.resolution)
        if steps.size:
            t = steps[None, :]
            keep = t < extent[:, None]
            px = (ox + t * np.cos(ang)[:, None])[keep]
            py = (oy + t * np.sin(ang)[:, None])[keep]
            self._set_cells(np.column_stack([px, py]), False)
        mark = hit & (rng <= self.obstacle_max_range)
        self._set_cells(np.column_stack([ox + rng[mark] * np.cos(ang[mark]),
                                         oy + rng[mark] * np.sin(ang[mark])]), True)
        self._refresh()

    def clear_dynamic(self, around: tuple[float, float, float] | None = None) -> None:
        if around is None:
            self._marked[:] = False
        else:  # a disc about (x, y): what the scans built elsewhere is the robot's map, and stays
            x, y, r = around
            xs, ys = self.grid.cell_centres()
            self._marked[(xs - x) ** 2 + (ys - y) ** 2 <= r * r] = False
        self._refresh()

    def add_keepout(self, polygon: Polygon) -> None:
        self._keepout |= polygon_mask(self.grid, polygon)
        self.keepouts.append([(float(x), float(y)) for x, y in polygon])
        self._refresh()

    def clear_keepouts(self) -> None:
        self._keepout[:] = False
        self.keepouts.clear()
        self._refresh()

    def copy(self) -> LayeredCostmap:
        """An independent costmap with the same layers (e.g. one per robot over a shared static map)."""
        other = LayeredCostmap.__new__(LayeredCostmap)
        other.__dict__.update(self.__dict__)
        other.grid = self.grid.copy()
        other._marked = self._marked.copy()
        other._keepout = self._keepout.copy()
        other.keepouts = [list(k) for k in self.keepouts]
        other._refresh()
        return other

    def _set_cells(self, xy: np.ndarray, value: bool) -> None:
        rows, cols = self.grid.world_to_cells(xy)
        ok = self.grid.in_bounds_many(rows, cols)
        self._marked[rows[ok], cols[ok]] = value

    def _refresh(self) -> None:
        """Recompute distance field, costs and free mask from the layers."""
        self._lethal = self._static | self._marked | self._keepout
        res = self.grid.resolution
        if self._lethal.any():
            self._dist = distance_transform_edt(~self._lethal) * res
        else:
            self._dist = np.full(self._lethal.shape, np.inf)
        self._surface = np.clip(np.minimum(self._dist, 1e6) - 0.5 * res, 0.0, None)
        d = self._dist
        decay = 252.0 * np.exp(-self.cost_scaling_factor * np.maximum(d - self.inscribed, 0.0))
        costs = np.where(d <= self.inflation_radius, np.rint(decay), 0).astype(np.uint8)
        costs[d <= self.inscribed] = INSCRIBED
        unknown = self._unknown & ~self._lethal
        costs[unknown & (costs < INSCRIBED)] = UNKNOWN
        costs[self._lethal] = LETHAL
        self._costs = costs
        free = d > self.inscribed
        if not self.allow_unknown:
            free &= ~unknown
        self._free = free
        self.version = next(_VERSIONS)


def segment_cells_points(grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
    """One point inside every cell the segment a→b passes through (exact supercover, endpoints included):
    midpoints between consecutive grid-line crossings."""
    p0 = np.asarray(a, dtype=float)
    d = np.asarray(b, dtype=float) - p0
    ts = [np.array([0.0, 1.0])]
    for k in range(2):
        if abs(d[k]) > 1e-15:
            lo, hi = sorted((p0[k], p0[k] + d[k]))
            o = grid.origin[k]
            lines = o + grid.resolution * np.arange(math.ceil((lo - o) / grid.resolution),
                                                    math.floor((hi - o) / grid.resolution) + 1)
            ts.append((lines - p0[k]) / d[k])
    t = np.unique(np.clip(np.concatenate(ts), 0.0, 1.0))
    mids = np.concatenate([[0.0], 0.5 * (t[:-1] + t[1:]), [1.0]])
    return p0 + mids[:, None] * d
