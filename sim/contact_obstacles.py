"""Robot–obstacle broadphase: which (robot, obstacle) pairs might penetrate, conservatively, in numpy.

Static obstacles within robot height are measured once per model-registry version: each one's footprint is
its own rectangle (an upright box: centre, heading, half sizes) or circle (an upright cylinder), or else its
axis-aligned box; the footprints, grown by the largest robot circle, are binned into a uniform grid, and a
robot reads the list of its cell. Moving (non-static) models are few and measured now: their axis-aligned
boxes against every robot. Every candidate then passes the robot's oriented box against the footprint.
"""

from __future__ import annotations

import math
import weakref
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pybullet as p

from sim.contact_broadphase import GROW, Hulls, boxes_overlap, expand_ranges, hulls, oriented

if TYPE_CHECKING:
    from sim.robot_table import RobotTable

MAX_CELLS = 1 << 16  # grid cells at least 1 m, and no more than this many
UPRIGHT = 1e-9  # rad: a primitive tilted less than this has its own footprint (else its AABB's)


class Footprints(NamedTuple):
    """xy footprints of obstacles, grown by GROW: an oriented rectangle each, and a circle radius (> 0 for a
    round one, which must also touch the circle); lo/hi: axis-aligned bounds of the footprint."""

    which: np.ndarray  # positions in the obstacle arrays they came from
    cx: np.ndarray
    cy: np.ndarray
    c: np.ndarray
    s: np.ndarray
    hx: np.ndarray
    hy: np.ndarray
    r: np.ndarray
    lo: np.ndarray  # (m, 2)
    hi: np.ndarray


class Grid(NamedTuple):
    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    starts: np.ndarray  # (nx * ny + 1,) offsets into `items` per cell
    items: np.ndarray  # footprint rows, ascending within each cell


_static: weakref.WeakKeyDictionary[object, tuple[tuple[object, ...], Footprints, Grid]] = weakref.WeakKeyDictionary()


def _shape(client: int, uid: int, lo: np.ndarray, hi: np.ndarray) -> tuple[float, ...]:
    """(cx, cy, cos, sin, half x, half y, radius) of one obstacle's footprint."""
    aabb = ((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 1.0, 0.0, (hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, 0.0)
    if p.getNumJoints(uid, physicsClientId=client) != 0:
        return aabb
    shapes = p.getCollisionShapeData(uid, -1, physicsClientId=client)
    if len(shapes) != 1 or shapes[0][2] not in (p.GEOM_BOX, p.GEOM_CYLINDER):
        return aabb
    _, _, kind, dims, _, lpos, lorn = shapes[0]
    pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    (x, y, _), q = p.multiplyTransforms(pos, orn, lpos, lorn)
    roll, pitch, yaw = p.getEulerFromQuaternion(q)
    if abs(roll) > UPRIGHT or abs(pitch) > UPRIGHT:
        return aabb
    if kind == p.GEOM_BOX:  # dims: full sizes
        return (x, y, math.cos(yaw), math.sin(yaw), dims[0] / 2, dims[1] / 2, 0.0)
    return (x, y, 1.0, 0.0, dims[1], dims[1], dims[1])  # cylinder: dims (length, radius)


def _footprints(rows: list[tuple[float, ...]], which: np.ndarray) -> Footprints:
    cx, cy, c, s, hx, hy, r = (np.array(col, dtype=float) for col in zip(*rows, strict=True))
    hx, hy, r = hx + GROW, hy + GROW, np.where(r > 0, r + GROW, 0.0)
    ex, ey = np.abs(c) * hx + np.abs(s) * hy, np.abs(s) * hx + np.abs(c) * hy  # half extents along x, y
    return Footprints(which, cx, cy, c, s, hx, hy, r, np.column_stack([cx - ex, cy - ey]),
                      np.column_stack([cx + ex, cy + ey]))


def _grid(fp: Footprints, grow: float) -> Grid:
    glo, ghi = fp.lo - grow, fp.hi + grow
    x0, y0 = float(glo[:, 0].min()), float(glo[:, 1].min())
    w, h = float(ghi[:, 0].max()) - x0, float(ghi[:, 1].max()) - y0
    cell = max(1.0, math.sqrt(w * h / MAX_CELLS))
    nx, ny = int(w // cell) + 1, int(h // cell) + 1
    c0 = np.floor((glo - (x0, y0)) / cell).astype(np.int64)
    c1 = np.minimum(np.floor((ghi - (x0, y0)) / cell).astype(np.int64), (nx - 1, ny - 1))
    cells, items = [], []
    for j in range(fp.which.size):
        gx, gy = np.meshgrid(np.arange(c0[j, 0], c1[j, 0] + 1), np.arange(c0[j, 1], c1[j, 1] + 1))
        cells.append((gy * nx + gx).ravel())
        items.append(np.full(gx.size, j, dtype=np.int64))
    allc, alli = np.concatenate(cells), np.concatenate(items)
    order = np.argsort(allc, kind="stable")  # footprint order kept within a cell
    return Grid(x0, y0, cell, nx, ny, np.searchsorted(allc[order], np.arange(nx * ny + 1)), alli[order])


def _touching(t: RobotTable, h: Hulls, k: np.ndarray, fp: Footprints, j: np.ndarray) -> np.ndarray:
    """Robot rows k against footprints j: circle vs bounds, oriented boxes, then circles for round ones."""
    f = t.f
    rx, ry, rr = f["x"][k], f["y"][k], h.rc[k]
    hit = (rx + rr >= fp.lo[j, 0]) & (rx - rr <= fp.hi[j, 0]) & (ry + rr >= fp.lo[j, 1]) & (ry - rr <= fp.hi[j, 1])
    k, j = k[hit], j[hit]
    bx, by, c, s, hx, hy = oriented(t, h, k)
    ok = boxes_overlap(bx, by, c, s, hx, hy, fp.cx[j], fp.cy[j], fp.c[j], fp.s[j], fp.hx[j], fp.hy[j])
    r = fp.r[j]
    dx, dy = fp.cx[j] - bx, fp.cy[j] - by  # the circle's centre in the robot box's frame, then its distance
    qx = np.maximum(np.abs(dx * c + dy * s) - hx, 0.0)
    qy = np.maximum(np.abs(dy * c - dx * s) - hy, 0.0)
    ok &= (r == 0) | (qx * qx + qy * qy <= r * r)
    hit[hit] = ok
    return hit


def static_pairs(t: RobotTable, rows: np.ndarray, owner: object, client: int, uids: np.ndarray, lo3: np.ndarray,
                 hi3: np.ndarray, top: float) -> tuple[np.ndarray, np.ndarray]:
    """(robot row, obstacle position) of the robots in rows whose box may touch a static obstacle within robot
    height (z from 0 to `top`), in rows' order, then obstacle order. (uids, lo3, hi3): the registry's static
    obstacle AABBs; the footprints and grid are cached while it hands out the same arrays."""
    h = hulls(t)
    grow = float(h.rc.max())
    hit = _static.get(owner)
    if hit is None or hit[0][0] is not lo3 or hit[0][1] is not hi3 or hit[0][2:] != (top, grow):
        which = np.flatnonzero((lo3[:, 2] <= top) & (hi3[:, 2] >= 0.0))
        if which.size == 0:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        fp = _footprints([_shape(client, int(uids[j]), lo3[j], hi3[j]) for j in which], which)
        hit = ((lo3, hi3, top, grow), fp, _grid(fp, grow))
        _static[owner] = hit
    _, fp, g = hit
    f = t.f
    gx = np.floor((f["x"][rows] - g.x0) / g.cell).astype(np.int64)
    gy = np.floor((f["y"][rows] - g.y0) / g.cell).astype(np.int64)
    inside = (gx >= 0) & (gx < g.nx) & (gy >= 0) & (gy < g.ny)
    cell = (gy * g.nx + gx)[inside]
    who, at = expand_ranges(g.starts[cell], g.starts[cell + 1])
    k, j = rows[inside][who], g.items[at]
    ok = _touching(t, h, k, fp, j)
    return k[ok], fp.which[j[ok]]


def moving_pairs(t: RobotTable, rows: np.ndarray, lo3: np.ndarray, hi3: np.ndarray,
                 top: float) -> tuple[np.ndarray, np.ndarray]:
    """static_pairs for non-static models, from their axis-aligned boxes measured now (every robot × model)."""
    which = np.flatnonzero((lo3[:, 2] <= top) & (hi3[:, 2] >= 0.0))
    if which.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lo, hi = lo3[which, :2], hi3[which, :2]
    fp = _footprints([((a + b) / 2, (c + d) / 2, 1.0, 0.0, (b - a) / 2, (d - c) / 2, 0.0)
                      for (a, c), (b, d) in zip(lo.tolist(), hi.tolist(), strict=True)], which)
    k, j = np.repeat(rows, which.size), np.tile(np.arange(which.size), rows.size)
    ok = _touching(t, hulls(t), k, fp, j)
    return k[ok], which[j[ok]]
