"""Hit/miss evidence of the local map's scans, kept incrementally, to drop what later scans saw through.

The front end matches each scan against the recent scans' returns. A return that other scans of the window
looked straight through — a person walking by, a door that opened, a grazing-angle or mixed-pixel return —
still attracts the match as strongly as a wall seen every time. A probability grid (Cartographer's submaps,
hit/miss odds updates) weighs each cell by how consistently it was seen; here the same evidence filters the
local map's points: a point is kept when its cell's log-odds, summed over the window's scans
(+`hit` per scan with a return in the cell, `miss` per scan whose beam crossed it), is above a threshold.

Counts are integers per cell, so a scan leaving the window (or moved by a loop closure) is subtracted
exactly; each scan is ray-cast once when it joins and once when it leaves.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from slam import se2
from slam.mapping import grow_to_cover

_GROW_MARGIN = 10.0  # m added around a scan when the grid must grow, so it rarely reallocates


class HitMissGrid:
    def __init__(self, resolution: float = 0.05, hit: float = 0.85, miss: float = -0.4) -> None:
        self.resolution = resolution
        self.hit, self.miss = hit, miss
        self.hits = np.zeros((0, 0), dtype=np.int32)
        self.misses = np.zeros((0, 0), dtype=np.int32)
        self.origin_cell = np.zeros(2, dtype=np.int64)  # world cell (col, row) of [0, 0]
        self.members: dict[int, tuple[se2.PoseTuple, np.ndarray]] = {}  # scan → (pose, points) it was added with

    def sync(self, idx: Iterable[int] | np.ndarray, poses: list[se2.PoseTuple], points: list[np.ndarray],
             tolerance: tuple[float, float] = (0.01, 0.002)) -> None:
        """Make the grid hold scans `idx` at `poses[k]`: remove those that left the window or moved by more than
        `tolerance` (m, rad; a loop closure moves every pose a little, and re-casting a whole window for
        millimetres would cost more than the rest of the step), add the new ones."""
        want = {int(k) for k in idx}

        def moved(k: int, pose: se2.PoseTuple) -> bool:
            p = poses[k]
            return (math.hypot(p[0] - pose[0], p[1] - pose[1]) > tolerance[0]
                    or abs(math.remainder(p[2] - pose[2], math.tau)) > tolerance[1])

        for k in [k for k, (pose, _) in self.members.items() if k not in want or moved(k, pose)]:
            pose, pts = self.members.pop(k)
            self._apply(pose, pts, -1)
        for k in sorted(want - self.members.keys()):
            self._apply(poses[k], points[k], +1)
            self.members[k] = (poses[k], points[k])

    def log_odds(self, xy: np.ndarray) -> np.ndarray:
        """Summed log-odds at world points `xy` (n, 2); 0 outside the grid."""
        c = np.floor(np.asarray(xy, dtype=np.float64).reshape(-1, 2) / self.resolution).astype(np.int64)
        c -= self.origin_cell
        h, w = self.hits.shape
        ok = (c[:, 0] >= 0) & (c[:, 0] < w) & (c[:, 1] >= 0) & (c[:, 1] < h)
        out = np.zeros(len(c))
        r, q = c[ok, 1], c[ok, 0]
        out[ok] = self.hit * self.hits[r, q] + self.miss * self.misses[r, q]
        return out

    def _apply(self, pose: se2.PoseTuple, points: np.ndarray, sign: int) -> None:
        """Add (sign +1) or remove (−1) one scan: every cell counted at most once per scan, a return's cell as
        a hit only. Free space stops 1.5 cells short of each return (as `slam.mapping`), so range noise on a
        surface does not count against the surface's own cell."""
        ends = se2.transform_points(pose, np.asarray(points, dtype=np.float64).reshape(-1, 2))
        if len(ends) == 0:
            return
        res = self.resolution
        origin = np.array(pose[:2])
        cells = np.floor(np.vstack([ends, origin[None]]) / res).astype(np.int64)
        self._ensure(cells.min(axis=0), cells.max(axis=0))
        lo = cells.min(axis=0) - self.origin_cell
        hi = cells.max(axis=0) - self.origin_cell + 1
        shape = (int(hi[1] - lo[1]), int(hi[0] - lo[0]))
        free = np.zeros(shape, dtype=bool)
        vec = ends - origin
        length = np.hypot(vec[:, 0], vec[:, 1])
        s = np.arange(0.0, float(length.max()), 0.7 * res)
        unit = vec / np.maximum(length, 1e-9)[:, None]
        base = origin / res - (self.origin_cell + lo)
        cx = np.floor(base[0] + s[None, :] * unit[:, 0:1] / res).astype(np.int64)
        cy = np.floor(base[1] + s[None, :] * unit[:, 1:2] / res).astype(np.int64)
        keep = s[None, :] < (length[:, None] - 1.5 * res)
        free[np.clip(cy[keep], 0, shape[0] - 1), np.clip(cx[keep], 0, shape[1] - 1)] = True
        hit = np.zeros(shape, dtype=bool)
        hc = cells[:-1] - self.origin_cell - lo
        hit[hc[:, 1], hc[:, 0]] = True
        free &= ~hit
        win = (slice(int(lo[1]), int(hi[1])), slice(int(lo[0]), int(hi[0])))
        self.hits[win] += sign * hit
        self.misses[win] += sign * free

    def _ensure(self, lo: np.ndarray, hi: np.ndarray) -> None:
        """Grow the arrays so world cells lo..hi (inclusive, (col, row)) are inside."""
        (self.hits, self.misses), self.origin_cell = grow_to_cover(
            [self.hits, self.misses], self.origin_cell, lo, hi, math.ceil(_GROW_MARGIN / self.resolution))
