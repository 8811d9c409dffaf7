"""A navigation function over an ObstacleMap: cost-to-go from every cell to the goal, inflation as cost.

The robot centre may use a cell when its distance to the nearest obstacle is at least the footprint's
inscribed half-width + the safety margin (less one cell of grid slack: the exact footprint check on the path
and in the controller decides the last centimetres). Closer to obstacles than `inflation_radius` a cell costs
more, decaying exponentially (Nav2's inflation layer as a cost gradient, not a wall): a path hugs the middle
of a gap but still takes any gap the footprint fits. Unknown cells (never swept by a beam) are traversable at
an extra cost (`unknown: optimistic`, Nav2's allow_unknown) or forbidden (`pessimistic`).

`plan_path` follows the field downhill, and checks the path with the exact rectangle at the path's heading.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.ndimage import distance_transform_edt, map_coordinates
from scipy.sparse.csgraph import dijkstra

from planning.obstacle_map import ObstacleMap
from planning.rect_footprint import RectFootprint
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

Unknown = Literal["optimistic", "pessimistic"]
NEIGHBOURS = ((0, 1, 1.0), (1, 0, 1.0), (1, 1, math.sqrt(2.0)), (1, -1, math.sqrt(2.0)))


@dataclass(frozen=True)
class FieldParams:
    margin: float = 0.05  # m between footprint and obstacles
    inflation_radius: float = 0.8  # m beyond the inscribed half-width + margin where cost stays above 1
    cost_weight: float = 4.0  # extra cost factor at the edge of the allowed space
    cost_decay: float = 5.0  # 1/m
    unknown: Unknown = "optimistic"
    unknown_cost: float = 0.3  # extra cost factor of an unknown cell (optimistic)


class NavField:
    """Cost-to-go (m, weighted) from every cell of `omap` (or of a `window` of it) to `goal`; `inf` where the
    goal is unreachable."""

    def __init__(self, omap: ObstacleMap, goal: Pose2D, footprint: RectFootprint, params: FieldParams,
                 window: tuple[float, float, float, float] | None = None,
                 blocked: Sequence[tuple[float, float, float]] = ()) -> None:
        self.omap, self.goal, self.footprint, self.params = omap, goal, footprint, params
        self.version = omap.version
        res = omap.resolution
        h0, w0 = omap.shape
        if window is None:
            r0, c0, r1, c1 = 0, 0, h0, w0
        else:
            (ra, rb), (ca, cb) = omap.cells(np.array([[window[0], window[1]], [window[2], window[3]]]))
            r0, c0 = max(0, int(ra)), max(0, int(ca))
            r1, c1 = min(h0, int(rb) + 1), min(w0, int(cb) + 1)
        self.r0, self.c0 = r0, c0
        self.origin = (omap.origin[0] + c0 * res, omap.origin[1] + r0 * res)
        dist = omap.distance_field()[r0:r1, c0:c1]
        seen = omap.seen[r0:r1, c0:c1]
        self.need = footprint.inscribed + params.margin
        free = dist >= self.need - res
        if params.unknown == "pessimistic":
            free &= seen
        if blocked:  # discs (x, y, r) the robot found it cannot pass: the field routes around them
            xs = self.origin[0] + (np.arange(free.shape[1]) + 0.5) * res
            ys = self.origin[1] + (np.arange(free.shape[0]) + 0.5) * res
            for bx, by, br in blocked:
                free &= ((xs[None, :] - bx) ** 2 + (ys[:, None] - by) ** 2) > br * br
        excess = np.maximum(dist - self.need, 0.0)
        weight = 1.0 + params.cost_weight * np.exp(-params.cost_decay * excess) * (excess < params.inflation_radius)
        if params.unknown == "optimistic":
            weight = weight + params.unknown_cost * ~seen
        self.free = free
        gr, gc = self._cells(np.array([[goal.x, goal.y]]))
        self.goal_cell = self._nearest_free(int(gr[0]), int(gc[0]))
        h, w = free.shape
        if self.goal_cell is None:
            self.ctg = np.full((h, w), np.inf)
        else:
            graph = _graph(free, weight * res)
            raw = dijkstra(graph, directed=False, indices=self.goal_cell[0] * w + self.goal_cell[1])
            self.ctg = np.asarray(raw).reshape(h, w)
        self._smooth = self._filled()

    def _nearest_free(self, r: int, c: int, radius_cells: int = 6) -> tuple[int, int] | None:
        h, w = self.free.shape
        best: tuple[float, int, int] | None = None
        for rr in range(max(0, r - radius_cells), min(h, r + radius_cells + 1)):
            for cc in range(max(0, c - radius_cells), min(w, c + radius_cells + 1)):
                if self.free[rr, cc]:
                    d = (rr - r) ** 2 + (cc - c) ** 2
                    if best is None or d < best[0]:
                        best = (d, rr, cc)
        return None if best is None else (best[1], best[2])

    def _filled(self) -> np.ndarray:
        """The field everywhere: a cell the robot may not use takes its nearest reachable cell's value plus
        a steep penalty per metre, so a robot pushed too close is led back out (downhill) at once."""
        finite = np.isfinite(self.ctg)
        if not finite.any():
            return np.full(self.ctg.shape, 1e6)
        d, (ir, ic) = distance_transform_edt(~finite, return_indices=True)
        return np.where(finite, self.ctg, self.ctg[ir, ic] + 10.0 * d * self.omap.resolution)

    def _cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = self.omap.cells(xy)
        return rows - self.r0, cols - self.c0

    def reachable(self, x: float, y: float) -> bool:
        r, c = self._cells(np.array([[x, y]]))
        h, w = self.ctg.shape
        return bool(0 <= r[0] < h and 0 <= c[0] < w) and bool(np.isfinite(self.ctg[r[0], c[0]]))

    def value(self, xy: npt.ArrayLike) -> np.ndarray:
        """Bilinear cost-to-go at points (outside the map: large)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        res = self.omap.resolution
        fr = (xy[:, 1] - self.origin[1]) / res - 0.5
        fc = (xy[:, 0] - self.origin[0]) / res - 0.5
        return np.asarray(map_coordinates(self._smooth, [fr, fc], order=1, mode="nearest"))

    def descent(self, start: tuple[float, float], max_steps: int = 20000) -> np.ndarray:
        """The grid path downhill from `start` to the goal cell, (n, 2) cell centres (empty if unreachable)."""
        rs, cs = self._cells(np.array([start]))
        r, c = int(rs[0]), int(cs[0])
        h, w = self.ctg.shape
        if not (0 <= r < h and 0 <= c < w) or not np.isfinite(self.ctg[r, c]):
            return np.zeros((0, 2))
        cells = [(r, c)]
        steps = [(dr, dc, math.hypot(dr, dc)) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
        while (r, c) != self.goal_cell and len(cells) < max_steps:
            best, nxt = self.ctg[r, c], None
            for dr, dc, _ in steps:
                rr, cc = r + dr, c + dc
                if 0 <= rr < h and 0 <= cc < w and self.ctg[rr, cc] < best:
                    best, nxt = self.ctg[rr, cc], (rr, cc)
            if nxt is None:
                break
            r, c = nxt
            cells.append(nxt)
        rc = np.array(cells)
        res = self.omap.resolution
        return np.column_stack([self.origin[0] + (rc[:, 1] + 0.5) * res, self.origin[1] + (rc[:, 0] + 0.5) * res])


def _graph(free: np.ndarray, weight: np.ndarray) -> sp.csr_matrix:
    """8-connected graph of free cells (no corner cutting), edge cost = length × mean cell weight."""
    h, w = free.shape
    idx = np.arange(h * w).reshape(h, w)
    rows, cols, vals = [], [], []
    for dr, dc, length in NEIGHBOURS:
        a = (slice(0, h - dr), slice(max(0, -dc), w - max(0, dc)))
        b = (slice(dr, h), slice(max(0, dc), w - max(0, -dc)))
        ok = free[a] & free[b]
        if dr and dc:
            ok &= free[(a[0], b[1])] & free[(b[0], a[1])]
        rows.append(idx[a][ok])
        cols.append(idx[b][ok])
        vals.append(length * 0.5 * (weight[a][ok] + weight[b][ok]))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(h * w, h * w))


def path_poses(path: np.ndarray, step: float = 0.02) -> np.ndarray:
    """(n, 3) poses every `step` along a polyline, heading along the path."""
    out = []
    for p, q in itertools.pairwise(path):
        seg = float(np.hypot(*(q - p)))
        if seg < 1e-12:
            continue
        yaw = math.atan2(q[1] - p[1], q[0] - p[0])
        t = np.arange(0.0, seg, step) / seg
        out.append(np.column_stack([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), np.full(t.size, yaw)]))
    if not out:
        return np.zeros((0, 3))
    last = out[-1][-1]
    return np.vstack([*out, [[path[-1][0], path[-1][1], last[2]]]])


def shortcut(path: np.ndarray, ok: Callable[[np.ndarray, np.ndarray], bool]) -> np.ndarray:
    """Greedy line-of-sight shortcut: from each kept point jump to the farthest point `ok(a, b)` accepts."""
    if len(path) <= 2:
        return path
    out, i = [path[0]], 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not ok(path[i], path[j]):
            j = max(i + 1, i + (j - i) // 2) if j - i > 8 else j - 1
        out.append(path[j])
        i = j
    return np.array(out)


def plan_path(omap: ObstacleMap, start: Pose2D, goal: Pose2D, footprint: RectFootprint,
              params: FieldParams) -> tuple[np.ndarray, float]:
    """A collision-free path for the exact footprint (heading along the path) and its minimum clearance.

    Raises PLANNING_FAILED naming the footprint and margin when no path keeps the margin everywhere."""
    omap.ensure((min(start.x, goal.x) - 2.0, min(start.y, goal.y) - 2.0,
                 max(start.x, goal.x) + 2.0, max(start.y, goal.y) + 2.0))
    field = NavField(omap, goal, footprint, params)
    need = footprint.describe(params.margin)
    raw = field.descent((start.x, start.y))
    if len(raw) == 0:
        raise FleetError(ErrorCode.PLANNING_FAILED, f"no path from ({start.x:.2f}, {start.y:.2f}) to "
                         f"({goal.x:.2f}, {goal.y:.2f}) for {need}: every way is narrower than footprint + margin",
                         "lower the safety margin, or check the map")
    raw = np.vstack([[start.x, start.y], raw[1:-1], [goal.x, goal.y]]) if len(raw) > 2 else \
        np.array([[start.x, start.y], [goal.x, goal.y]])

    def clear(a: np.ndarray, b: np.ndarray) -> bool:
        poses = path_poses(np.array([a, b]))
        mid = 0.5 * (a + b)
        return bool(footprint.distances(poses, omap.points_near(float(mid[0]), float(mid[1]), _reach(a, b, footprint)))
                    .min(initial=np.inf) >= params.margin - 1e-9)

    path = shortcut(raw, clear)
    poses = path_poses(path)
    pts = omap.points
    d = _chunked_distances(footprint, poses, pts)
    worst = int(np.argmin(d)) if d.size else 0
    if d.size and d[worst] < params.margin - 1e-9:
        x, y, _ = poses[worst]
        raise FleetError(ErrorCode.PLANNING_FAILED,
                         f"no path for {need}: the best way passes ({x:.2f}, {y:.2f}) with only "
                         f"{max(float(d[worst]), 0.0):.3f} m between footprint and obstacle",
                         "lower the safety margin, or widen the gap")
    return path, float(d.min()) if d.size else math.inf


def _reach(a: np.ndarray, b: np.ndarray, fp: RectFootprint) -> float:
    return 0.5 * float(np.hypot(*(b - a))) + fp.circumscribed + 0.5


def _chunked_distances(fp: RectFootprint, poses: np.ndarray, pts: np.ndarray, chunk: int = 256) -> np.ndarray:
    if len(pts) == 0:
        return np.full(len(poses), np.inf)
    from scipy.spatial import cKDTree

    tree = cKDTree(pts)
    out = np.empty(len(poses))
    for k in range(0, len(poses), chunk):
        p = poses[k:k + chunk]
        centre = p[:, :2].mean(axis=0)
        span = float(np.hypot(*(p[:, :2].max(axis=0) - p[:, :2].min(axis=0))))
        near = pts[tree.query_ball_point(centre, span / 2 + fp.circumscribed + 1.0)]
        out[k:k + len(p)] = fp.distances(p, near)
    return out
