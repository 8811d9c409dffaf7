"""Fresh, exact penetration queries for robots: a numpy broadphase, then PyBullet's getClosestPoints per pair.

PyBullet's cached contact manifolds can under-report penetration right after teleports (seen in
benchmarks/sim_throughput.py: −0.6 mm reported where getClosestPoints measured −2.2 mm), so kinematic
collision handling measures candidate pairs afresh instead of reading performCollisionDetection's cache.

The broadphase is conservative (it never drops a pair getClosestPoints would find in penetration): a sweep
along x over circles about base_link, then a separating-axis test of oriented rectangles. A kinematic robot's
rectangle is its collision shapes' bounding box in its own frame (`hull_columns`, measured once at spawn), so
only pairs whose boxes overlap pay the engine query; a dynamic robot (it may tilt) keeps its footprint circle.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

if TYPE_CHECKING:
    from sim.robot_table import RobotTable
    from sim.world import World

PENETRATION = -1e-3  # m: distances below this are overlaps, not grazing contacts
ROBOT_TOP = 0.7  # m: robots' AABB height for the obstacle broadphase (lidar housing included)
GROW = 1e-3  # m: every box and circle grown by this, so float rounding never drops a touching pair
Penetration = tuple[int, int, tuple[float, float, float], float]  # uid a, uid b, position on a, distance
Boxes = tuple[np.ndarray, ...]  # base x, y, bounding radius, box centre x, y, cos, sin, half x, half y


def hull_columns(client: int, uid: int) -> dict[str, float]:
    """The robot table's hull columns of a one-body robot proxy: its collision shapes' bounding rectangle in
    base_link's frame, read as its AABB while it stands unrotated at the origin (where robots are created)."""
    lo, hi = p.getAABB(uid, -1, physicsClientId=client)
    return {"hull_x0": lo[0], "hull_x1": hi[0], "hull_y0": lo[1], "hull_y1": hi[1]}


def robot_boxes(t: RobotTable) -> Boxes:
    f = t.f
    kin = t.b["kinematic"] & (f["hull_x1"] > f["hull_x0"])  # rows with a measured hull
    x, y, r = f["x"], f["y"], f["radius"]
    x0, x1 = np.where(kin, f["hull_x0"], -r) - GROW, np.where(kin, f["hull_x1"], r) + GROW
    y0, y1 = np.where(kin, f["hull_y0"], -r) - GROW, np.where(kin, f["hull_y1"], r) + GROW
    # circle about base_link holding the box (a dynamic robot's is its footprint circle)
    rc = np.where(kin, np.hypot(np.maximum(-x0, x1), np.maximum(-y0, y1)), r + GROW)
    c, s = np.cos(f["yaw"]), np.sin(f["yaw"])
    lx, ly = (x0 + x1) / 2, (y0 + y1) / 2
    return x, y, rc, x + c * lx - s * ly, y + s * lx + c * ly, c, s, (x1 - x0) / 2, (y1 - y0) / 2


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
    total = int(cnt.sum())
    owner = np.repeat(np.arange(cnt.size), cnt)
    return owner, np.arange(total) - np.repeat(np.cumsum(cnt) - cnt - start, cnt)


def _robot_robot(bx: Boxes, in_rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows (a, b) of robot pairs whose boxes overlap, at least one in rows; a is in rows (the lower if both)."""
    x, y, rc, cx, cy, c, s, hx, hy = bx
    order = np.argsort(x, kind="stable")
    xs = x[order]
    reach = 2.0 * float(rc.max())
    i, j = expand_ranges(np.arange(1, xs.size + 1), np.searchsorted(xs, xs + reach, side="right"))
    a, b = order[i], order[j]
    keep = (in_rows[a] | in_rows[b]) & (np.abs(y[b] - y[a]) <= reach)
    a, b = a[keep], b[keep]
    keep = np.hypot(x[b] - x[a], y[b] - y[a]) <= rc[a] + rc[b]
    a, b = a[keep], b[keep]
    keep = boxes_overlap(cx[a], cy[a], c[a], s[a], hx[a], hy[a], cx[b], cy[b], c[b], s[b], hx[b], hy[b])
    lo, hi = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    first = np.where(in_rows[lo], lo, hi)
    second = np.where(in_rows[lo], hi, lo)
    order = np.lexsort((second, first))
    return first[order], second[order]


def _robot_obstacle(bx: Boxes, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(robot row, obstacle index) of the robots in rows whose box overlaps an obstacle's xy box, ordered by
    rows' order, then obstacle. Each obstacle sweeps the robots sorted along its shorter side."""
    x, y, rc, cx, cy, c, s, hx, hy = bx
    grow = float(rc[rows].max())
    ks, js = [], []
    narrow_x = hi[:, 0] - lo[:, 0] <= hi[:, 1] - lo[:, 1]
    for pos, mine in ((x, np.flatnonzero(narrow_x)), (y, np.flatnonzero(~narrow_x))):
        axis = 0 if pos is x else 1
        if mine.size == 0:
            continue
        order = rows[np.argsort(pos[rows], kind="stable")]
        ps = pos[order]
        owner, k = expand_ranges(np.searchsorted(ps, lo[mine, axis] - grow, side="left"),
                           np.searchsorted(ps, hi[mine, axis] + grow, side="right"))
        ks.append(order[k])
        js.append(mine[owner])
    if not ks:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    k, j = np.concatenate(ks), np.concatenate(js)
    rx, ry, rr = x[k], y[k], rc[k]
    hit = (rx + rr >= lo[j, 0]) & (rx - rr <= hi[j, 0]) & (ry + rr >= lo[j, 1]) & (ry - rr <= hi[j, 1])
    k, j = k[hit], j[hit]
    ocx, ocy = (lo[j, 0] + hi[j, 0]) / 2, (lo[j, 1] + hi[j, 1]) / 2
    ohx, ohy = (hi[j, 0] - lo[j, 0]) / 2, (hi[j, 1] - lo[j, 1]) / 2
    one, zero = np.ones(j.size), np.zeros(j.size)
    hit = boxes_overlap(cx[k], cy[k], c[k], s[k], hx[k], hy[k], ocx, ocy, one, zero, ohx, ohy)
    k, j = k[hit], j[hit]
    where = np.zeros(rc.size, dtype=np.int64)
    where[rows] = np.arange(rows.size)
    order = np.lexsort((j, where[k]))  # as a rows × obstacles scan would list them
    return k[order], j[order]


def candidate_pairs(world: World, rows: np.ndarray) -> list[tuple[int, int]]:
    """Pairs (robot uid, other uid) that might penetrate, for the robots in `rows`: robot pairs whose boxes
    overlap, then world bodies whose axis-aligned boxes (within robot height) overlap a robot's box."""
    t = world.table
    if rows.size == 0 or len(t) == 0:
        return []
    bx = robot_boxes(t)
    body = t.body
    pairs: list[tuple[int, int]] = []
    if len(t) > 1:
        in_rows = np.zeros(len(t), dtype=bool)
        in_rows[rows] = True
        a, b = _robot_robot(bx, in_rows)
        pairs += zip(body[a].tolist(), body[b].tolist(), strict=True)
    uids, lo, hi = world.models.obstacle_aabbs()
    if uids.size:
        tall = (lo[:, 2] <= ROBOT_TOP) & (hi[:, 2] >= 0.0)
        if tall.any():
            k, j = _robot_obstacle(bx, rows, lo[tall, :2] - GROW, hi[tall, :2] + GROW)
            pairs += zip(body[k].tolist(), uids[tall][j].tolist(), strict=True)
    return pairs


def penetrations(world: World, pairs: list[tuple[int, int]]) -> list[Penetration]:
    """The deepest point of every pair in penetration, measured now."""
    out = []
    closest, c = p.getClosestPoints, world.client
    for a, b in pairs:
        pts = closest(a, b, 0.0, physicsClientId=c)
        if not pts:
            continue
        deepest = min(pts, key=lambda ct: ct[8])
        if deepest[8] < PENETRATION:
            pos = deepest[5]
            out.append((a, b, (pos[0], pos[1], pos[2]), float(deepest[8])))
    return out


def robot_penetrations(world: World, rows: np.ndarray | None = None) -> list[Penetration]:
    """Every penetration involving the robots in `rows` (all robots by default)."""
    idx = np.arange(len(world.table)) if rows is None else rows
    return penetrations(world, candidate_pairs(world, idx))
