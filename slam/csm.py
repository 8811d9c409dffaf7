"""Correlative scan matching (Olson 2009; Hess et al. 2016 real-time CSM + branch-and-bound).

A `MatchGrid` holds a smoothed hit likelihood of a point set (exp(−d²/2σ²) of the distance to the nearest
point) and, per level h, the maximum over every 2^h × 2^h block of
cells starting at each cell. A search scores every rotation of the scan in a window; the translations are
found by branch and bound: a block's precomputed maximum is an upper bound on the score of every
translation inside it, so whole blocks are pruned without evaluating them. The result is the exact best
pose on the window's lattice, which ICP then refines below a cell.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slam import se2

_TOP_CHUNK = 32  # rotations scored at once on the top level (an index block that stays in cache)
_CHILD_CHUNK = 2048  # blocks scored at once below it


class MatchGrid:
    def __init__(self, points: np.ndarray, resolution: float = 0.05, sigma: float = 0.07,
                 margin: float = 1.0) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        self.resolution = res = resolution
        lo = pts.min(axis=0) - margin
        hi = pts.max(axis=0) + margin
        self.origin = lo
        w, h = (np.ceil((hi - lo) / res).astype(int) + 1).tolist()
        # max over the points of exp(−d²/2σ²), cut at 4σ: stamp a kernel on every hit cell, weakest offsets
        # first, so each cell ends with its largest value (cheaper than a distance transform of the grid)
        c = np.floor((pts - lo) / res).astype(np.int64)
        c = c[first_per_cell(c)]
        r = math.ceil(4.0 * sigma / res)
        dy, dx = np.mgrid[-r:r + 1, -r:r + 1]
        wk = np.exp(-0.5 * (dx ** 2 + dy ** 2) * (res / sigma) ** 2)
        inside = (dx ** 2 + dy ** 2) * res ** 2 <= (4.0 * sigma) ** 2
        order = np.argsort(wk[inside])
        # stamp in place when the kernel cannot leave the grid (the usual margin), else on a padded copy
        pad = 0 if (c.min() >= r and int(c[:, 0].max()) + r < w and int(c[:, 1].max()) + r < h) else r
        field = np.zeros((h + 2 * pad, w + 2 * pad), dtype=np.float32)
        flat = (c[:, 1] + pad) * (w + 2 * pad) + (c[:, 0] + pad)
        out = field.ravel()
        for ox, oy, val in zip(dx[inside][order].tolist(), dy[inside][order].tolist(),
                               wk[inside][order].tolist(), strict=True):
            out[flat + (oy * (w + 2 * pad) + ox)] = val
        if pad:
            field = np.ascontiguousarray(field[pad:pad + h, pad:pad + w])
        self._levels = [_zero_border(field)]
        # cells on every side of level 0 that are zero whatever the points (margin minus the kernel radius)
        self.zero_margin = max(0, math.floor(margin / res) - r - 2)

    @property
    def field(self) -> np.ndarray:
        return self._levels[0]

    def level(self, h: int) -> np.ndarray:
        """Max over the 2^h × 2^h block of cells starting at each cell (zero outside the grid)."""
        while len(self._levels) <= h:
            prev = self._levels[-1]
            s = 1 << (len(self._levels) - 1)
            # max with the block s columns on, then s rows on. Both as one pass over the flat arrays (3× faster
            # than strided 2-D views); a cell of the last s columns, which met the next row's first cells there,
            # is then set back to its own value, as is each of the last s rows.
            w = prev.shape[1]
            nxt = np.empty(prev.shape, prev.dtype)  # C order: ravel() below is a view
            np.maximum(prev.ravel()[:-s], prev.ravel()[s:], out=nxt.ravel()[:-s])
            nxt[:, -s:] = prev[:, -s:]
            nxt2 = np.empty(prev.shape, prev.dtype)
            np.maximum(nxt.ravel()[:-s * w], nxt.ravel()[s * w:], out=nxt2.ravel()[:-s * w])
            nxt2[-s:, :] = nxt[-s:, :]
            self._levels.append(_zero_border(nxt2))
        return self._levels[h]

    def cells(self, xy: np.ndarray) -> np.ndarray:
        """(…, 2) world points → integer (col, row) cells (may be off the grid)."""
        return np.floor((xy - self.origin) / self.resolution).astype(np.int64)

    def score(self, pose: se2.PoseTuple, points: np.ndarray) -> float:
        """Mean field value of the points placed at `pose` (0 … 1)."""
        c = self.cells(se2.transform_points(pose, points))
        return float(_lookup(self._levels[0], c[:, 0], c[:, 1]).mean()) if len(c) else 0.0


def first_per_cell(cells: np.ndarray) -> np.ndarray:
    """Sorted indices of the first row of each distinct (col, row) pair: np.unique(axis=0, return_index=True)
    on a 1-D key (a row-wise unique sorts whole rows and is ~10× slower)."""
    if len(cells) == 0:
        return np.zeros(0, dtype=np.int64)
    lo = cells.min(axis=0)
    span = int(cells[:, 1].max() - lo[1]) + 1
    key = (cells[:, 0] - lo[0]) * span + (cells[:, 1] - lo[1])
    _, first = np.unique(key, return_index=True)
    return np.sort(first)



def thin(points: np.ndarray, spacing: float) -> np.ndarray:
    """One point per `spacing` cell (the first in scan order), scan order kept."""
    if len(points) == 0:
        return points
    return points[first_per_cell(np.floor(points / spacing).astype(np.int64))]


def subsample(points: np.ndarray, n: int) -> np.ndarray:
    """At most n points, evenly spaced in scan order."""
    return points if len(points) <= n else points[np.linspace(0, len(points) - 1, n).astype(int)]


def _zero_border(a: np.ndarray) -> np.ndarray:
    a[0, :] = a[-1, :] = 0.0
    a[:, 0] = a[:, -1] = 0.0
    return a


def _lookup(grid: np.ndarray, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """grid[rows, cols], off-grid cells read as 0. Viewed as unsigned, a negative index becomes huge, so one
    minimum clamps both sides onto the last row/column, which is a zero border (3× faster than two-sided
    clipping and fancy indexing on two arrays; this is the search's inner loop)."""
    h, w = grid.shape
    rows, cols = np.asarray(rows), np.asarray(cols)
    small = rows.dtype == np.int32 and cols.dtype == np.int32 and h * w < 2 ** 31
    signed, unsigned = (np.int32, np.uint32) if small else (np.int64, np.uint64)
    r = np.minimum(rows.astype(signed, copy=False).view(unsigned), unsigned(h - 1))
    r *= unsigned(w)
    r += np.minimum(cols.astype(signed, copy=False).view(unsigned), unsigned(w - 1))
    return np.take(grid.ravel(), r)


@dataclass(frozen=True, slots=True)
class CsmResult:
    pose: se2.PoseTuple
    score: float  # mean field value at the best lattice pose, 0 … 1
    nodes: int  # branch-and-bound nodes expanded (cost diagnostic)


def search(grid: MatchGrid, points: np.ndarray, guess: se2.PoseTuple, *, window_xy: float, window_yaw: float,
           min_score: float = 0.0, max_range_for_step: float = 10.0, top_level: int | None = None,
           prior_weight_xy: float = 0.0, prior_weight_yaw: float = 0.0) -> CsmResult | None:
    """Best pose of `points` (sensor frame) within ±window_xy, ±window_yaw of `guess`, or None if no pose
    scores above `min_score`. The score may be penalised by the distance from the guess
    (score − w_xy·‖Δt‖² − w_yaw·Δθ²); the bound stays valid since a block's penalty uses its nearest point."""
    res = grid.resolution
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return None
    rmax = min(max_range_for_step, float(np.hypot(pts[:, 0], pts[:, 1]).max()))
    step = math.acos(max(-1.0, 1.0 - res * res / (2.0 * max(rmax, res) ** 2)))
    na = math.ceil(window_yaw / step)
    angles = guess[2] + step * np.arange(-na, na + 1)
    nw = math.ceil(window_xy / res)
    depth = top_level if top_level is not None else max(0, math.ceil(math.log2(max(2 * nw + 1, 1))))
    # every rotation's points in cells, relative to the window's lowest corner
    c, s = np.cos(angles), np.sin(angles)
    rx = c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1] + guess[0]
    ry = s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1] + guess[1]
    # (A, n) each, as grid.cells computes them; int32 halves traffic
    bx = np.floor((rx - grid.origin[0]) / res).astype(np.int32) - np.int32(nw)
    by = np.floor((ry - grid.origin[1]) / res).astype(np.int32) - np.int32(nw)
    n = len(pts)
    size = 2 * nw + 1
    block = 1 << depth
    starts = np.arange(0, size, block, dtype=np.int32)
    gx, gy = np.meshgrid(starts, starts, indexing="ij")
    ox, oy = gx.ravel(), gy.ravel()
    top = grid.level(depth)
    hh, ww = top.shape
    # If every level's zero margin is at least the window, a point either keeps all its lookups inside the
    # grid or has all of them in the margin or off the grid (all 0, so it can read the zero corner instead):
    # one flat index per point and rotation then replaces the per-axis clamping (same scores, ~2× faster).
    flat: np.ndarray | None = None
    if grid.zero_margin - block + 1 >= size and hh * ww < 2 ** 31:
        inside = (bx >= 0) & (by >= 0) & (bx + size <= ww) & (by + size <= hh)
        flat = np.where(inside, by * ww + bx, 0).astype(np.int32)  # (A, n)
    # top level: every rotation × every block, vectorised
    if flat is not None:
        sums = np.empty((len(angles), len(ox)), dtype=top.dtype)
        off = (oy * ww + ox)[None, :, None]
        for i in range(0, len(angles), _TOP_CHUNK):  # a few rotations at a time: the index block stays in cache
            sums[i:i + _TOP_CHUNK] = np.take(top.ravel(), flat[i:i + _TOP_CHUNK, None, :] + off).sum(-1)
        sc = sums / n
    else:
        sc = _lookup(top, bx[:, None, :] + ox[None, :, None], by[:, None, :] + oy[None, :, None]).sum(-1) / n
    sc = sc - _penalty(ox, oy, block, nw, res, prior_weight_xy)[None, :]
    sc = sc - (prior_weight_yaw * (angles - guess[2]) ** 2)[:, None]
    yaw_pen = prior_weight_yaw * (angles - guess[2]) ** 2
    a_idx, k_idx = np.nonzero(sc > min_score)
    if len(a_idx) == 0:
        return None
    cand = (a_idx, ox[k_idx], oy[k_idx], sc[a_idx, k_idx])

    def children(c: tuple[np.ndarray, ...], h: int) -> tuple[np.ndarray, ...]:
        """The four sub-blocks (level h−1) of every block in `c` (level h), scored on level h−1."""
        half = 1 << (h - 1)
        a = np.repeat(c[0], 4)
        x = (c[1][:, None] + np.array([0, half, 0, half], dtype=np.int32)[None, :]).ravel()
        y = (c[2][:, None] + np.array([0, 0, half, half], dtype=np.int32)[None, :]).ravel()
        keep = (x < size) & (y < size)
        a, x, y = a[keep], x[keep], y[keep]
        lv = grid.level(h - 1)
        v = np.empty(len(a))
        ch = _CHILD_CHUNK
        for k in range(0, len(a), ch):  # chunks bound the (blocks × points) working set
            if flat is not None:
                off = y[k:k + ch] * ww + x[k:k + ch]
                v[k:k + ch] = np.take(lv.ravel(), flat[a[k:k + ch]] + off[:, None]).sum(-1)
                continue
            v[k:k + ch] = _lookup(lv, bx[a[k:k + ch]] + x[k:k + ch, None], by[a[k:k + ch]] + y[k:k + ch, None]).sum(-1)
        return a, x, y, v / n - _penalty(x, y, half, nw, res, prior_weight_xy) - yaw_pen[a]

    # Greedy descent from the best top block gives a reachable leaf: its score is a lower bound that prunes.
    best_score, best = min_score, None
    g = tuple(v[[int(np.argmax(cand[3]))]] for v in cand)
    for h in range(depth, 0, -1):
        g = children(g, h)
        i = int(np.argmax(g[3])) if len(g[0]) else -1
        if i < 0:
            break
        g = tuple(v[[i]] for v in g)
    if depth == 0:
        g = cand
    if len(g[0]) and float(g[3].max()) > best_score:
        i = int(np.argmax(g[3]))
        best_score, best = float(g[3][i]), (int(g[0][i]), int(g[1][i]), int(g[2][i]))
    # Then branch and bound, one level at a time (all surviving blocks of a level at once).
    nodes = 0
    live = tuple(v[cand[3] > best_score] for v in cand)
    for h in range(depth, 0, -1):
        if len(live[0]) == 0:
            break
        nodes += len(live[0])
        ch = children(live, h)
        keep = ch[3] > best_score
        live = tuple(v[keep] for v in ch)
        if h - 1 == 0 and len(live[0]):
            i = int(np.argmax(live[3]))
            best_score, best = float(live[3][i]), (int(live[0][i]), int(live[1][i]), int(live[2][i]))
    if best is None:
        return None
    a, x0, y0 = best
    pose = (guess[0] + (x0 - nw) * res, guess[1] + (y0 - nw) * res, float(angles[a]))
    return CsmResult(pose, best_score, nodes)


def _penalty(ox: np.ndarray, oy: np.ndarray, block: int, nw: int, res: float, w: float) -> np.ndarray:
    """w·(smallest squared offset from the guess inside each block), m²."""
    if w <= 0:
        return np.zeros(len(ox))
    def nearest(o: np.ndarray) -> np.ndarray:
        lo, hi = o - nw, o - nw + block - 1
        return np.where((lo <= 0) & (hi >= 0), 0, np.minimum(np.abs(lo), np.abs(hi))) * res
    return w * (nearest(ox) ** 2 + nearest(oy) ** 2)
