"""Conservative broadphase for robot contacts, all in numpy: which pairs might penetrate (sim/contact_query.py).

It never drops a pair whose shapes overlap: circles about base_link first, then a separating-axis test of
oriented rectangles. A kinematic robot's rectangle is its collision shapes' bounding box in its own frame
(the table's hull columns, measured once at spawn) and its circle is the one holding that box; a dynamic
robot (it may tilt) keeps its footprint circle (and the square around it). Every box and circle is grown by
GROW so float rounding never drops a touching pair.

- Robot pairs: robots sorted by (stripe of y, x), stripes as tall as the largest pair reach, so each robot
  meets only the robots of its own and the next stripe within reach along x (a few, not a column of the map).
- Robot–obstacle pairs: the obstacles' xy boxes, grown by the largest robot circle, are binned once into a
  uniform grid (cached while the obstacles' boxes stay the same arrays); a robot reads its cell's list.
"""

from __future__ import annotations

import math
import weakref
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from sim.robot_table import RobotTable

GROW = 1e-3  # m
MAX_CELLS = 1 << 16  # obstacle grid: cells at least 1 m, and no more than this many


class Hulls(NamedTuple):
    """Per robot row: box centre and half sizes in the robot's frame (grown by GROW), radius of the circle
    about base_link holding the box. Rebuilt only when the table's rows change (spawn, removal, snapshot restore)."""

    lx: np.ndarray
    ly: np.ndarray
    hx: np.ndarray
    hy: np.ndarray
    rc: np.ndarray
    r0: np.ndarray  # the circle about base_link holding the box before growing (≥ the footprint radius)


class Grid(NamedTuple):
    which: np.ndarray  # obstacles within robot height: their positions in the obstacle arrays
    lo: np.ndarray  # (m, 2) their xy boxes, grown by GROW
    hi: np.ndarray
    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    starts: np.ndarray  # (nx * ny + 1,) CSR offsets into `items` per cell
    items: np.ndarray  # rows of lo/hi, ascending within each cell


# Caches keyed by identity: the key arrays are held, so their ids cannot be reused while cached.
_hulls: dict[int, tuple[tuple[np.ndarray, ...], Hulls]] = {}
_grids: weakref.WeakKeyDictionary[object, tuple[tuple[object, ...], Grid | None]] = weakref.WeakKeyDictionary()


def hulls(t: RobotTable) -> Hulls:
    f = t.f
    key = (f["hull_x0"], f["hull_x1"], f["hull_y0"], f["hull_y1"], f["radius"], t.b["kinematic"])
    hit = _hulls.get(id(key[0]))
    if hit is not None and all(a is b for a, b in zip(hit[0], key, strict=True)):
        return hit[1]
    kin = t.b["kinematic"] & (f["hull_x1"] > f["hull_x0"])  # rows with a measured hull
    r = f["radius"]
    x0, x1 = np.where(kin, f["hull_x0"], -r) - GROW, np.where(kin, f["hull_x1"], r) + GROW
    y0, y1 = np.where(kin, f["hull_y0"], -r) - GROW, np.where(kin, f["hull_y1"], r) + GROW
    rc = np.where(kin, np.hypot(np.maximum(-x0, x1), np.maximum(-y0, y1)), r + GROW)
    r0 = np.maximum(r, np.where(kin, np.hypot(np.maximum(-f["hull_x0"], f["hull_x1"]),
                                              np.maximum(-f["hull_y0"], f["hull_y1"])), r))
    out = Hulls((x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2, rc, r0)
    if len(_hulls) > 16:  # tables come and go (worlds, spawns): keep a few
        _hulls.clear()
    _hulls[id(key[0])] = (key, out)
    return out


def boxes_overlap(ax: np.ndarray, ay: np.ndarray, ac: np.ndarray, as_: np.ndarray, ahx: np.ndarray,
                  ahy: np.ndarray, bx: np.ndarray, by: np.ndarray, bc: np.ndarray, bs: np.ndarray, bhx: np.ndarray,
                  bhy: np.ndarray) -> np.ndarray:
    """Separating-axis test of oriented rectangles (centre, cos/sin of heading, half sizes): True where no
    axis of either rectangle separates them."""
    dx, dy = bx - ax, by - ay
    cd, sd = np.abs(ac * bc + as_ * bs), np.abs(as_ * bc - ac * bs)  # |cos|, |sin| of the heading difference
    return ((np.abs(dx * ac + dy * as_) <= ahx + bhx * cd + bhy * sd)
            & (np.abs(dy * ac - dx * as_) <= ahy + bhx * sd + bhy * cd)
            & (np.abs(dx * bc + dy * bs) <= bhx + ahx * cd + ahy * sd)
            & (np.abs(dy * bc - dx * bs) <= bhy + ahx * sd + ahy * cd))


def expand_ranges(start: np.ndarray, end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owner, index) of every index in the half-open ranges [start, end), owner = the range's position."""
    cnt = np.maximum(end - start, 0)
    owner = np.repeat(np.arange(cnt.size), cnt)
    return owner, np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt - start, cnt)


Oriented = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _oriented(t: RobotTable, h: Hulls, k: np.ndarray) -> Oriented:
    """World box centre x, y, cos, sin, half x, half y of robot rows k."""
    f = t.f
    yaw = f["yaw"][k]
    c, s = np.cos(yaw), np.sin(yaw)
    lx, ly = h.lx[k], h.ly[k]
    return f["x"][k] + c * lx - s * ly, f["y"][k] + s * lx + c * ly, c, s, h.hx[k], h.hy[k]


def robot_robot(t: RobotTable, in_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows (a, b) of robot pairs whose boxes overlap, at least one in rows; a is in rows (the lower if both),
    sorted by (a, b)."""
    f, h = t.f, hulls(t)
    x, y, rc = f["x"], f["y"], h.rc
    reach = 2.0 * float(rc.max()) + 1e-6
    xs = x - float(x.min())
    width = float(xs.max()) + 2.0 * reach + 1.0  # keys of one stripe never reach the next stripe's
    key = np.floor((y - float(y.min())) / reach) * width + xs
    order = np.argsort(key)
    ks = key[order]
    same = expand_ranges(np.arange(1, ks.size + 1), np.searchsorted(ks, ks + reach, side="right"))
    above = expand_ranges(np.searchsorted(ks, ks + (width - reach), side="left"),
                          np.searchsorted(ks, ks + (width + reach), side="right"))
    a, b = order[np.concatenate([same[0], above[0]])], order[np.concatenate([same[1], above[1]])]
    keep = (in_rows[a] | in_rows[b]) & (np.hypot(x[b] - x[a], y[b] - y[a]) <= rc[a] + rc[b])
    a, b = a[keep], b[keep]
    keep = boxes_overlap(*_oriented(t, h, a), *_oriented(t, h, b))
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    first = np.where(in_rows[lo], lo, hi)
    second = np.where(in_rows[lo], hi, lo)
    order = np.lexsort((second, first))
    return first[order], second[order]


def _grid(owner: object, lo3: np.ndarray, hi3: np.ndarray, top: float, grow: float) -> Grid | None:
    """The obstacles within robot height (z from 0 to `top`), their xy boxes grown by `grow` binned into cells;
    cached per owner while it hands out the same box arrays (static obstacles are measured once)."""
    hit = _grids.get(owner)
    if hit is not None and hit[0][0] is lo3 and hit[0][1] is hi3 and hit[0][2:] == (top, grow):
        return hit[1]
    index = np.flatnonzero((lo3[:, 2] <= top) & (hi3[:, 2] >= 0.0))
    out = None
    if index.size:
        lo, hi = lo3[index, :2] - GROW, hi3[index, :2] + GROW
        glo, ghi = lo - grow, hi + grow
        x0, y0 = float(glo[:, 0].min()), float(glo[:, 1].min())
        w, h = float(ghi[:, 0].max()) - x0, float(ghi[:, 1].max()) - y0
        cell = max(1.0, math.sqrt(w * h / MAX_CELLS))
        nx, ny = int(w // cell) + 1, int(h // cell) + 1
        c0 = np.floor((glo - (x0, y0)) / cell).astype(np.int64)
        c1 = np.minimum(np.floor((ghi - (x0, y0)) / cell).astype(np.int64), (nx - 1, ny - 1))
        cells, items = [], []
        for j in range(index.size):
            gx, gy = np.meshgrid(np.arange(c0[j, 0], c1[j, 0] + 1), np.arange(c0[j, 1], c1[j, 1] + 1))
            cells.append((gy * nx + gx).ravel())
            items.append(np.full(gx.size, j, dtype=np.int64))
        allc, alli = np.concatenate(cells), np.concatenate(items)
        order = np.argsort(allc, kind="stable")  # obstacle order kept within a cell
        starts = np.searchsorted(allc[order], np.arange(nx * ny + 1), side="left")
        out = Grid(index, lo, hi, x0, y0, cell, nx, ny, starts, alli[order])
    _grids[owner] = ((lo3, hi3, top, grow), out)
    return out


def robot_obstacle(t: RobotTable, rows: np.ndarray, owner: object, lo3: np.ndarray, hi3: np.ndarray,
                   top: float) -> tuple[np.ndarray, np.ndarray]:
    """(robot row, obstacle index) of the robots in rows whose box overlaps the xy box of an obstacle within
    robot height (lo3, hi3: (m, 3) AABBs, z from 0 to `top`), in rows' order, then obstacle order."""
    f, h = t.f, hulls(t)
    g = _grid(owner, lo3, hi3, top, float(h.rc.max()))
    if g is None:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    gx = np.floor((f["x"][rows] - g.x0) / g.cell).astype(np.int64)
    gy = np.floor((f["y"][rows] - g.y0) / g.cell).astype(np.int64)
    inside = (gx >= 0) & (gx < g.nx) & (gy >= 0) & (gy < g.ny)
    cell = (gy * g.nx + gx)[inside]
    who, at = expand_ranges(g.starts[cell], g.starts[cell + 1])
    k, j = rows[inside][who], g.items[at]
    lo, hi = g.lo[j], g.hi[j]
    rx, ry, rr = f["x"][k], f["y"][k], h.rc[k]
    hit = (rx + rr >= lo[:, 0]) & (rx - rr <= hi[:, 0]) & (ry + rr >= lo[:, 1]) & (ry - rr <= hi[:, 1])
    k, j, lo, hi = k[hit], j[hit], lo[hit], hi[hit]
    one = np.ones(j.size)
    hit = boxes_overlap(*_oriented(t, h, k), (lo[:, 0] + hi[:, 0]) / 2, (lo[:, 1] + hi[:, 1]) / 2, one,
                        np.zeros(j.size), (hi[:, 0] - lo[:, 0]) / 2, (hi[:, 1] - lo[:, 1]) / 2)
    return k[hit], g.which[j[hit]]
