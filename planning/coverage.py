"""Coverage paths over a polygon with holes (shapely): boustrophedon decomposition, or a spiral.

The tool is a disc of diameter `tool_width` centred on the robot; neighbouring passes are spaced
d = tool_width · (1 − overlap) apart. The tool centre stays inside the region shrunk by tool_width/2 (the
"centre domain"), so the tool never leaves the region.

Boustrophedon (Choset): sweep lines at angle `angle` (default: along the long side of the region's minimum
rotated rectangle, so there are fewest passes). Lanes across a span S of the centre domain number
n = ceil(S / d) + 1 (one lane when S ≈ 0), spaced S / (n − 1) ≤ d, so the first and last passes touch the
region's edges: for a W-wide rectangle, n = ceil((W − w) / (w·(1 − overlap))) + 1. Lane intervals are linked
into cells where the sweep's connectivity does not change (no split or merge, e.g. at a hole); each cell is
driven back and forth, cells in nearest-first order, transits inside the centre domain (visibility graph).

Spiral: the centre domain's boundary, then its offsets inward by d, each ring (outer and around holes)
driven once, nearest ring next.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, MultiPolygon, Point, Polygon

from planning.nav_types import CoveragePlan
from sim.errors import ErrorCode, FleetError

Pattern = Literal["boustrophedon", "spiral"]
XY = tuple[float, float]


def plan_coverage(region: Polygon | Sequence[XY], *, tool_width: float, overlap: float = 0.1,
                  pattern: Pattern = "boustrophedon", holes: Sequence[Sequence[XY]] = (),
                  angle: float | None = None, start: XY | None = None) -> CoveragePlan:
    """A path covering `region` (a shapely Polygon, or exterior vertices plus `holes`)."""
    poly = _region(region, holes)
    if not (math.isfinite(tool_width) and tool_width > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"tool_width must be > 0, got {tool_width}", "e.g. 0.4 m")
    if not 0.0 <= overlap < 1.0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"overlap must be in [0, 1), got {overlap}", "e.g. 0.1")
    domain = poly.buffer(-tool_width / 2, join_style="mitre")
    if domain.is_empty:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "the region is not wider than the tool",
                         f"use a tool narrower than {tool_width} m or a larger region")
    spacing = tool_width * (1.0 - overlap)
    here = np.array(start if start is not None else poly.exterior.coords[0], dtype=float)
    if pattern == "boustrophedon":
        th = _sweep_angle(poly) if angle is None else angle
        path, swaths, cells = _boustrophedon(domain, spacing, th, here)
        passes = len(swaths)
    elif pattern == "spiral":
        path, passes = _spiral(domain, spacing, tool_width / 2, here)
        swaths, cells = [], 1
    else:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown coverage pattern '{pattern}'",
                         "patterns: boustrophedon, spiral")
    cov, ovl = coverage_stats(path, poly, tool_width)
    return CoveragePlan(path=path, pattern=pattern, tool_width=tool_width, overlap=overlap, passes=passes,
                        cells=cells, length=_length(path), area=float(poly.area), coverage_pct=cov,
                        overlap_pct=ovl, swaths=tuple(swaths))


def coverage_stats(path: np.ndarray, region: Polygon, tool_width: float) -> tuple[float, float]:
    """(coverage %, overlap %) of a disc tool of that width moved along `path` (see CoveragePlan)."""
    line = LineString(path) if len(path) > 1 else Point(path[0])
    swept = line.buffer(tool_width / 2)
    covered = swept.intersection(region).area
    repeat = max(0.0, _length(path) * tool_width - swept.area)
    return 100.0 * covered / region.area, 100.0 * repeat / max(swept.area, 1e-12)


# ---- boustrophedon ----------------------------------------------------------------------------------------


def _boustrophedon(domain: Polygon | MultiPolygon, spacing: float, angle: float,
                   here: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], int]:
    rot = affinity.rotate(domain, -angle, origin=(0, 0), use_radians=True)  # lanes along +x
    cells = [_cell_lanes(rot, cell, spacing) for cell in _decompose(rot)]
    c, s = math.cos(angle), math.sin(angle)
    to_world = np.array([[c, -s], [s, c]])
    walk = _Walker(rot, to_world.T @ here)
    swaths: list[np.ndarray] = []
    remaining = list(range(len(cells)))
    while remaining:  # nearest cell entry next; each cell back and forth from the corner we reach first
        k, bottom_up, left_first = min(((k, b, lf) for k in remaining for b in (True, False) for lf in (True, False)),
                                       key=lambda o: _entry_dist(cells[o[0]], o[1], o[2], walk.pos))
        remaining.remove(k)
        rows = cells[k] if bottom_up else cells[k][::-1]
        for i, (y, x0, x1) in enumerate(rows):
            a, b = ((x0, y), (x1, y)) if (i % 2 == 0) == left_first else ((x1, y), (x0, y))
            walk.go(np.array(a))
            walk.go(np.array(b), straight=True)
            swaths.append(np.array([to_world @ a, to_world @ b]))
    path = np.array(walk.points) @ to_world.T
    return _dedupe(path), swaths, len(cells)


Trapezoid = tuple[float, float, tuple[float, float]]  # (y_lo, y_hi, x-interval at mid height)


def _decompose(rot: Polygon | MultiPolygon) -> list[list[Trapezoid]]:
    """Boustrophedon cells: slabs between consecutive vertex heights cut the domain into trapezoids; a
    trapezoid continues the cell below when each is the other's only neighbour (no split, no merge)."""
    ys = np.unique(np.round([y for g in getattr(rot, "geoms", [rot]) for r in (g.exterior, *g.interiors)
                             for _, y in r.coords], 9))
    eps = 1e-7
    cells: list[list[Trapezoid]] = []
    prev_top: list[tuple[float, float]] = []
    prev_cell: list[int] = []
    for y0, y1 in itertools.pairwise(ys):
        if y1 - y0 < 2 * eps:
            continue
        bottom, mid, top = (_intervals(rot, y) for y in (y0 + eps, (y0 + y1) / 2, y1 - eps))
        if not (len(bottom) == len(mid) == len(top)):  # numerically degenerate slab: skip its splits
            bottom = top = mid
        cur_cell = []
        for j, (a, b) in enumerate(bottom):
            ups = [i for i, (c, d) in enumerate(prev_top) if c < b + eps and a < d + eps]
            only = len(ups) == 1 and sum(1 for c, d in bottom if c < prev_top[ups[0]][1] + eps
                                         and prev_top[ups[0]][0] < d + eps) == 1
            if only:
                cell = prev_cell[ups[0]]
            else:
                cells.append([])
                cell = len(cells) - 1
            cells[cell].append((float(y0), float(y1), mid[j]))
            cur_cell.append(cell)
        prev_top, prev_cell = top, cur_cell
    return cells


def _cell_lanes(rot: Polygon | MultiPolygon, cell: list[Trapezoid], spacing: float) -> list[tuple[float, float, float]]:
    """n = ceil(span / d) + 1 lanes across the cell (first and last on its edges): (y, x0, x1) each."""
    y_lo, y_hi = cell[0][0], cell[-1][1]
    span = y_hi - y_lo
    n = 1 if span < 1e-6 else math.ceil(span / spacing - 1e-6) + 1
    eps = 1e-6
    ys = [y_lo + span / 2] if n == 1 else list(np.linspace(y_lo + eps, y_hi - eps, n))
    lanes = []
    for y in ys:
        a, b = next((m for lo, hi, m in cell if lo <= y <= hi), cell[-1][2])  # the trapezoid it crosses
        ivs = [iv for iv in _intervals(rot, y) if iv[0] < b and a < iv[1]]
        if ivs:
            lanes.append((float(y), ivs[0][0], ivs[0][1]))
    return lanes


def _intervals(rot: Polygon | MultiPolygon, y: float) -> list[tuple[float, float]]:
    xmin, _, xmax, _ = rot.bounds
    cut = rot.intersection(LineString([(xmin - 1.0, y), (xmax + 1.0, y)]))
    parts = [g for g in getattr(cut, "geoms", [cut]) if isinstance(g, LineString) and g.length > 1e-9]
    return sorted((min(p.coords[0][0], p.coords[-1][0]), max(p.coords[0][0], p.coords[-1][0])) for p in parts)


def _entry_dist(cell: list[tuple[float, float, float]], bottom_up: bool, left_first: bool, pos: np.ndarray) -> float:
    y, x0, x1 = cell[0] if bottom_up else cell[-1]
    return float(np.hypot((x0 if left_first else x1) - pos[0], y - pos[1]))


# ---- spiral -------------------------------------------------------------------------------------------------


def _spiral(domain: Polygon | MultiPolygon, spacing: float, half_tool: float,
            here: np.ndarray) -> tuple[np.ndarray, int]:
    rings: list[np.ndarray] = []
    level, k = domain, 0
    while not level.is_empty:
        for poly in getattr(level, "geoms", [level]):
            for ring in (poly.exterior, *poly.interiors):
                rings.append(np.asarray(ring.coords)[:-1])
            # the innermost offset may leave a core farther than half a tool from its ring: drive its ring too
            core = poly.buffer(-0.999 * half_tool, join_style="mitre")
            if poly.buffer(-spacing, join_style="mitre").is_empty and not core.is_empty:
                rings += [np.asarray(r.coords)[:-1] for c in getattr(core, "geoms", [core])
                          for r in (c.exterior, *c.interiors)]
        k += 1
        level = domain.buffer(-k * spacing, join_style="mitre")
    walk = _Walker(domain, here)
    todo = list(range(len(rings)))
    while todo:  # nearest ring next, entered at its nearest vertex, driven once around
        i = min(todo, key=lambda r: float(np.min(np.hypot(*(rings[r] - walk.pos).T))))
        todo.remove(i)
        ring = rings[i]
        j = int(np.argmin(np.hypot(*(ring - walk.pos).T)))
        loop = np.vstack([ring[j:], ring[:j], ring[j:j + 1]])
        walk.go(loop[0])
        for p in loop[1:]:
            walk.go(p, straight=True)
    return _dedupe(np.array(walk.points)), len(rings)


# ---- moving inside the centre domain -----------------------------------------------------------------------


class _Walker:
    """Appends points to a path; a jump that would leave the domain goes round through a visibility graph."""

    def __init__(self, domain: Polygon | MultiPolygon, start: np.ndarray) -> None:
        self.domain = domain.buffer(1e-9)  # boundary-following moves count as inside
        shapely.prepare(self.domain)
        self.points: list[np.ndarray] = []
        self.pos = np.asarray(start, dtype=float)
        self._nodes = np.array([c for poly in getattr(domain, "geoms", [domain])
                                for ring in (poly.exterior, *poly.interiors) for c in ring.coords[:-1]])

    def go(self, p: np.ndarray, straight: bool = False) -> None:
        if self.points and not straight and not self._visible(self.pos, p):
            self.points.extend(self._detour(self.pos, p))
        self.points.append(np.asarray(p, dtype=float))
        self.pos = np.asarray(p, dtype=float)

    def _visible(self, a: np.ndarray, b: np.ndarray) -> bool:
        return bool(self.domain.contains(LineString([a, b]))) if np.hypot(*(b - a)) > 1e-9 else True

    def _detour(self, a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
        """Interior vertices of the shortest path a → b through the domain's vertices (Dijkstra)."""
        nodes = np.vstack([a, b, self._nodes])
        n = len(nodes)
        lines = [LineString([nodes[i], nodes[j]]) for i in range(n) for j in range(i + 1, n)]
        ok = shapely.contains(self.domain, lines)
        adj: list[list[tuple[int, float]]] = [[] for _ in range(n)]
        pairs = ((i, j) for i in range(n) for j in range(i + 1, n))
        for (i, j), good in zip(pairs, ok, strict=True):
            if good:
                d = float(np.hypot(*(nodes[i] - nodes[j])))
                adj[i].append((j, d))
                adj[j].append((i, d))
        dist, prev, heap = {0: 0.0}, {0: -1}, [(0.0, 0)]
        while heap:
            d, u = heapq.heappop(heap)
            if u == 1:
                break
            if d > dist[u]:
                continue
            for v, w in adj[u]:
                if d + w < dist.get(v, math.inf):
                    dist[v], prev[v] = d + w, u
                    heapq.heappush(heap, (d + w, v))
        if 1 not in prev:
            return []  # a separate part of the domain: the navigator plans that transit itself
        out, u = [], prev[1]
        while u > 0:
            out.append(nodes[u])
            u = prev[u]
        return out[::-1]


# ---- helpers -------------------------------------------------------------------------------------------------


def _region(region: Polygon | Sequence[XY], holes: Sequence[Sequence[XY]]) -> Polygon:
    try:
        poly = region if isinstance(region, Polygon) else Polygon(region, [list(h) for h in holes])
    except (ValueError, TypeError) as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"not a polygon: {exc}",
                         "give >= 3 (x, y) vertices, and holes as lists of vertices") from exc
    if poly.is_empty or poly.area <= 0 or not poly.is_valid:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"invalid coverage region: {shapely.is_valid_reason(poly)}",
                         "use a simple polygon (no self-intersections) with holes inside it")
    return poly


def _sweep_angle(poly: Polygon) -> float:
    """Direction of the long side of the minimum rotated rectangle: passes along it are fewest."""
    rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    long = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
    return math.atan2(long[1], long[0])


def _dedupe(path: np.ndarray) -> np.ndarray:
    keep = np.r_[True, np.hypot(*np.diff(path, axis=0).T) > 1e-9]
    return path[keep]


def _length(path: np.ndarray) -> float:
    return float(np.hypot(*np.diff(path, axis=0).T).sum()) if len(path) > 1 else 0.0
