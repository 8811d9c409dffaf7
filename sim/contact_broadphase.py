"""Conservative broadphase for robot contacts, all in numpy: which pairs might penetrate (sim/contact_query.py).

It never drops a pair whose shapes overlap: circles about base_link first, then a separating-axis test of
oriented rectangles. A kinematic robot's rectangle is its collision shapes' bounding box in its own frame
(the table's hull columns, measured once at spawn) and its circle is the one holding that box; a dynamic
robot (it may tilt) keeps its footprint circle (and the square around it). Every box and circle is grown by
GROW so float rounding never drops a touching pair.

- Robot pairs: robots sorted by (stripe of y, x), stripes as tall as the largest pair reach, so each robot
  meets only the robots of its own and the next stripe within reach along x (a few, not a column of the map).
- Robot–obstacle pairs: sim/contact_obstacles.py (a cached grid of the static obstacles' exact footprints).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from sim.robot_table import RobotTable

GROW = 1e-3  # m


class Hulls(NamedTuple):
    """Per robot row: box centre and half sizes in the robot's frame (grown by GROW), radius of the circle
    about base_link holding the box. Rebuilt only when the table's rows change (spawn, removal, snapshot restore)."""

    lx: np.ndarray
    ly: np.ndarray
    hx: np.ndarray
    hy: np.ndarray
    rc: np.ndarray
    r0: np.ndarray  # the circle about base_link holding the box before growing (≥ the footprint radius)


# Caches keyed by identity: the key arrays are held, so their ids cannot be reused while cached.
_hulls: dict[int, tuple[tuple[np.ndarray, ...], Hulls]] = {}


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


def oriented(t: RobotTable, h: Hulls, k: np.ndarray) -> Oriented:
    """World box centre x, y, cos, sin, half x, half y of robot rows k."""
    f = t.f
    yaw = f["yaw"][k]
    c, s = np.cos(yaw), np.sin(yaw)
    lx, ly = h.lx[k], h.ly[k]
    return f["x"][k] + c * lx - s * ly, f["y"][k] + s * lx + c * ly, c, s, h.hx[k], h.hy[k]


def robot_robot(t: RobotTable, in_rows: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Rows (a, b) of robot pairs whose boxes overlap, at least one in rows (None: every robot); a is in rows
    (the lower if both), sorted by (a, b)."""
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
    keep = np.hypot(x[b] - x[a], y[b] - y[a]) <= rc[a] + rc[b]
    if in_rows is not None:
        keep &= in_rows[a] | in_rows[b]
    a, b = a[keep], b[keep]
    n = a.size
    bx, by, c, s, hx, hy = oriented(t, h, np.concatenate([a, b]))  # both ends in one pass
    keep = boxes_overlap(bx[:n], by[:n], c[:n], s[:n], hx[:n], hy[:n], bx[n:], by[n:], c[n:], s[n:], hx[n:], hy[n:])
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    if in_rows is not None:
        lo, hi = np.where(in_rows[lo], lo, hi), np.where(in_rows[lo], hi, lo)
    order = np.lexsort((hi, lo))
    return lo[order], hi[order]
