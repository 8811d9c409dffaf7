"""Rasterise a WorldDescription into an OccupancyGrid at robot height.

A cell is occupied when an obstacle footprint overlaps the cell square with positive area (not merely
its centre): thin walls never leak, and an axis-aligned box on cell edges covers exactly its cells.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from scipy.spatial import ConvexHull

from planning.grid import OCCUPIED, OccupancyGrid
from planning.shapes import DEFAULT_SLAB, Footprint, world_footprints
from planning.types import Polygon
from sim.errors import ErrorCode, FleetError
from sim.types import WorldDescription

_EPS = 1e-9  # m: a shape that only touches a cell edge does not occupy the cell


def rasterize_world(description: WorldDescription, *, resolution: float = 0.05,
                    slab: tuple[float, float] = DEFAULT_SLAB,
                    bounds: tuple[float, float, float, float] | None = None,
                    margin: float = 0.5) -> OccupancyGrid:
    """Occupancy of every collision reaching into the z `slab`, free elsewhere (nothing is unknown).

    `bounds` defaults to the footprints' extent grown by `margin` metres.
    """
    if not (slab[1] > slab[0]):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"slab {slab} is empty", "pass (z_low, z_high), z_high > z_low")
    footprints = world_footprints(description, slab)
    grid = OccupancyGrid.empty(bounds or footprint_bounds(footprints, margin), resolution)
    mask = np.zeros(grid.data.shape, dtype=bool)
    for fp in footprints:
        fill_footprint(mask, grid, fp)
    grid.data[mask] = OCCUPIED
    return grid


def footprint_bounds(footprints: list[Footprint], margin: float) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of all footprints plus margin; a 10 m square about 0 when there are none."""
    if not footprints:
        return (-5.0 - margin, -5.0 - margin, 5.0 + margin, 5.0 + margin)
    lo = np.min([_extent(fp)[0] for fp in footprints], axis=0) - margin
    hi = np.max([_extent(fp)[1] for fp in footprints], axis=0) + margin
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _extent(fp: Footprint) -> tuple[np.ndarray, np.ndarray]:
    if fp.vertices is not None:
        return fp.vertices.min(axis=0), fp.vertices.max(axis=0)
    c = np.asarray(fp.centre)
    return c - fp.radius, c + fp.radius


def fill_footprint(mask: np.ndarray, grid: OccupancyGrid, fp: Footprint) -> None:
    if fp.kind == "circle":
        fill_circle(mask, grid, fp.centre, fp.radius)
    elif fp.vertices is not None:
        fill_convex(mask, grid, fp.vertices)


def _window(grid: OccupancyGrid, lo: np.ndarray, hi: np.ndarray) -> tuple[slice, slice] | None:
    """Row/col slices of the cells whose squares may overlap the box [lo, hi]."""
    r0, c0 = grid.world_to_cell(float(lo[0]), float(lo[1]))
    r1, c1 = grid.world_to_cell(float(hi[0]), float(hi[1]))
    r0, c0 = max(r0, 0), max(c0, 0)
    r1, c1 = min(r1, grid.height - 1), min(c1, grid.width - 1)
    if r1 < r0 or c1 < c0:
        return None
    return slice(r0, r1 + 1), slice(c0, c1 + 1)


def _centres(grid: OccupancyGrid, win: tuple[slice, slice]) -> tuple[np.ndarray, np.ndarray]:
    rows = np.arange(win[0].start, win[0].stop)
    cols = np.arange(win[1].start, win[1].stop)
    xs = grid.origin[0] + (cols + 0.5) * grid.resolution
    ys = grid.origin[1] + (rows + 0.5) * grid.resolution
    return np.meshgrid(xs, ys)


def fill_circle(mask: np.ndarray, grid: OccupancyGrid, centre: tuple[float, float], radius: float) -> None:
    """Mark cells whose square overlaps the disc."""
    c = np.asarray(centre, dtype=float)
    win = _window(grid, c - radius, c + radius)
    if win is None or radius <= 0:
        return
    x, y = _centres(grid, win)
    h = grid.resolution / 2
    # Distance from the disc centre to the nearest point of each cell square.
    dx = np.maximum(np.abs(x - c[0]) - h, 0.0)
    dy = np.maximum(np.abs(y - c[1]) - h, 0.0)
    mask[win] |= dx * dx + dy * dy < (radius - _EPS) ** 2


def fill_convex(mask: np.ndarray, grid: OccupancyGrid, vertices: np.ndarray) -> None:
    """Mark cells whose square overlaps the convex polygon (any winding)."""
    v = np.asarray(vertices, dtype=float)
    win = _window(grid, v.min(axis=0), v.max(axis=0))
    if win is None:
        return
    h = grid.resolution / 2
    # A square centred at q overlaps the polygon iff q lies in polygon ⊕ square: hull of shifted vertices.
    shifted = np.vstack([v + np.array([sx * h, sy * h]) for sx in (-1, 1) for sy in (-1, 1)])
    hull = shifted[ConvexHull(shifted).vertices]  # CCW
    x, y = _centres(grid, win)
    inside = np.ones(x.shape, dtype=bool)
    for p, q in zip(hull, np.roll(hull, -1, axis=0), strict=True):
        e = q - p
        cross = e[0] * (y - p[1]) - e[1] * (x - p[0])
        inside &= cross > _EPS * math.hypot(*e)
    mask[win] |= inside


def polygon_mask(grid: OccupancyGrid, polygon: Polygon) -> np.ndarray:
    """Cells whose centre lies inside a simple polygon (convex or not), as a bool (height, width) array."""
    poly = shapely.Polygon(polygon)
    if not poly.is_valid or poly.area <= 0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"invalid polygon {list(polygon)}",
                         "give ≥ 3 (x, y) vertices of a simple, non-self-intersecting polygon")
    out = np.zeros(grid.data.shape, dtype=bool)
    xmin, ymin, xmax, ymax = poly.bounds
    win = _window(grid, np.array([xmin, ymin]), np.array([xmax, ymax]))
    if win is None:
        return out
    x, y = _centres(grid, win)
    out[win] = shapely.contains_xy(poly, x, y)
    return out
