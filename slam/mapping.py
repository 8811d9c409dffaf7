"""Log-odds occupancy mapping from posed scans; the grid grows as the robot explores.

Each scan updates every cell at most once: cells its beams pass through get the miss log-odds, the end
cells the hit log-odds (a hit wins over a pass in the same scan). Loop closures move the poses, so the
pipeline calls `rebuild` with the optimised poses rather than patching cells.
"""

from __future__ import annotations

import math

import numpy as np

from planning.grid import FREE_CELL, OCCUPIED, UNKNOWN_CELL, OccupancyGrid
from sim.errors import ErrorCode, FleetError
from slam import se2

_GROW_MARGIN = 5.0  # m added around the scan when the grid must grow, so it rarely reallocates


class OccupancyMapper:
    def __init__(self, *, resolution: float = 0.05, log_odds_hit: float = 0.85, log_odds_miss: float = -0.4,
                 log_odds_min: float = -2.0, log_odds_max: float = 3.5, occupied_threshold: float = 0.65,
                 free_threshold: float = 0.196, max_range: float = 10.0, clear_no_return: bool = True) -> None:
        self.resolution = resolution
        self._hit, self._miss = log_odds_hit, log_odds_miss
        self._lmin, self._lmax = log_odds_min, log_odds_max
        self._l_occ = math.log(occupied_threshold / (1 - occupied_threshold))
        self._l_free = math.log(free_threshold / (1 - free_threshold))
        self.max_range = max_range
        self.clear_no_return = clear_no_return
        self.log_odds = np.zeros((0, 0), dtype=np.float32)
        self.origin_cell = np.zeros(2, dtype=np.int64)  # world cell index (col, row) of log_odds[0, 0]
        self.scans = 0

    def clear(self) -> None:
        self.log_odds = np.zeros((0, 0), dtype=np.float32)
        self.scans = 0

    def integrate(self, sensor_pose: se2.PoseTuple, points: np.ndarray,
                  no_return_angles: np.ndarray | None = None) -> None:
        """Add one scan: `points` (n, 2) returns and `no_return_angles` beams without one, sensor frame."""
        ends = se2.transform_points(sensor_pose, np.asarray(points, dtype=np.float64).reshape(-1, 2))
        origin = np.array(sensor_pose[:2])
        hit_ok = np.hypot(*(ends - origin).T) <= self.max_range
        rays = ends
        if self.clear_no_return and no_return_angles is not None and len(no_return_angles):
            a = np.asarray(no_return_angles) + sensor_pose[2]
            far = origin + self.max_range * np.column_stack([np.cos(a), np.sin(a)])
            rays = np.vstack([ends, far])
        if len(rays) == 0:
            return
        res = self.resolution
        cells_all = np.floor(np.vstack([rays, origin[None]]) / res).astype(np.int64)
        self._ensure(cells_all.min(axis=0), cells_all.max(axis=0))
        # Every sample lies between the sensor and a beam end, so their cells' bounding box holds it all.
        lo = cells_all.min(axis=0) - self.origin_cell
        hi = cells_all.max(axis=0) - self.origin_cell + 1
        upd = np.zeros((int(hi[1] - lo[1]), int(hi[0] - lo[0])), dtype=np.float32)
        # Free space: a sample every 0.7 cell along each beam, stopping 1.5 cells short of its end, so a
        # surface on a cell boundary marks the cells on both sides (their centre line is the surface)
        # instead of the range noise clearing the front one: scan-to-map matching is then unbiased.
        # Samples past the stop are parked on the sensor's own cell (free anyway): arrays stay rectangular.
        vec = (rays - origin).astype(np.float32)
        length = np.hypot(vec[:, 0], vec[:, 1])
        s = np.arange(0.0, float(length.max()), 0.7 * res, dtype=np.float32)
        unit = vec / np.maximum(length, 1e-9)[:, None]
        base = origin.astype(np.float32) / np.float32(res) - (self.origin_cell + lo).astype(np.float32)
        inv = np.float32(1.0 / res)
        cx = np.floor(base[0] + (s[None, :] * unit[:, 0:1]) * inv).astype(np.int32)
        cy = np.floor(base[1] + (s[None, :] * unit[:, 1:2]) * inv).astype(np.int32)
        past = s[None, :] >= (length[:, None] - 1.5 * res)
        cx[past], cy[past] = int(np.floor(base[0])), int(np.floor(base[1]))
        # float32 rounding can land a sample a hair outside the box: clip rather than wrap around
        upd[np.clip(cy, 0, upd.shape[0] - 1), np.clip(cx, 0, upd.shape[1] - 1)] = self._miss
        hit = np.floor(ends[hit_ok] / res).astype(np.int64) - self.origin_cell - lo
        upd[hit[:, 1], hit[:, 0]] = self._hit  # a hit overrides a pass-through
        win = self.log_odds[lo[1]:hi[1], lo[0]:hi[0]]
        np.clip(win + upd, self._lmin, self._lmax, out=win)
        self.scans += 1

    def rebuild(self, sensor_poses: np.ndarray, scans: list[tuple[np.ndarray, np.ndarray]]) -> None:
        """Re-render from scratch with new poses (after a loop closure)."""
        self.clear()
        for pose, (pts, no_ret) in zip(sensor_poses, scans, strict=True):
            self.integrate((float(pose[0]), float(pose[1]), float(pose[2])), pts, no_ret)

    def _ensure(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Grow the array so world cells lo..hi (inclusive, (col, row)) are inside."""
        (self.log_odds,), self.origin_cell = grow_to_cover(
            [self.log_odds], self.origin_cell, lo, hi, math.ceil(_GROW_MARGIN / self.resolution))

    def grid(self, crop: bool = True) -> OccupancyGrid:
        """Trinary ROS grid (-1/0/100); `crop` trims unknown borders."""
        lo = self.log_odds
        if lo.size == 0:
            raise FleetError(ErrorCode.NOT_FOUND, "the map is empty: no scan has been integrated yet",
                             "process some scans first")
        data = np.full(lo.shape, UNKNOWN_CELL, dtype=np.int8)
        data[lo > self._l_occ] = OCCUPIED
        data[lo < self._l_free] = FREE_CELL
        off = self.origin_cell.copy()
        if crop and data.size and (data >= 0).any():
            rows = np.nonzero((data >= 0).any(axis=1))[0]
            cols = np.nonzero((data >= 0).any(axis=0))[0]
            data = data[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
            off = off + np.array([cols[0], rows[0]])
        origin = (float(off[0] * self.resolution), float(off[1] * self.resolution))
        return OccupancyGrid(np.ascontiguousarray(data), self.resolution, origin)


def grow_to_cover(arrays: list[np.ndarray], origin_cell: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  margin: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Same-shape 2-D grids (rows = y) whose [0, 0] is world cell `origin_cell` (col, row), grown with `margin`
    cells to spare so world cells lo..hi (inclusive) are inside; unchanged (the same arrays) when they already
    are. Returns (arrays, origin_cell)."""
    h, w = arrays[0].shape
    cur_lo, cur_hi = origin_cell, origin_cell + np.array([w, h]) - 1
    if h and w and np.all(lo >= cur_lo) and np.all(hi <= cur_hi):
        return arrays, origin_cell
    new_lo = np.minimum(lo - margin, cur_lo) if h and w else lo - margin
    new_hi = np.maximum(hi + margin, cur_hi) if h and w else hi + margin
    size = (int(new_hi[1] - new_lo[1] + 1), int(new_hi[0] - new_lo[0] + 1))
    grown = [np.zeros(size, dtype=a.dtype) for a in arrays]
    if h and w:
        off = cur_lo - new_lo
        for g, a in zip(grown, arrays, strict=True):
            g[off[1]:off[1] + h, off[0]:off[0] + w] = a
    return grown, new_lo
