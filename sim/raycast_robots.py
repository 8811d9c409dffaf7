"""Rays against upright robots (kinematic bodies posed by the robot table at (x, y, 0, yaw)) in closed form,
vectorised over (ray, robot) pairs: no BVH is built for them, so the static scene keeps the one BVH built at
load and robots that moved cost nothing to "update".

Pairs are found without testing every ray against every robot: consecutive rays with close origins form a
group (a lidar's beams), a disc holding their origins; a robot (plan radius ρ) at distance D from a group's
centre can only be hit by the group's rays whose heading lies within asin((ρ + h) / D) of the bearing to it
(the Minkowski sum of the two discs; _pairs narrows it further). Rays are sorted by (group, heading), so each
candidate (group, robot) pair is one or two `searchsorted` ranges: a lidar sees a neighbour's few beams.

Each candidate pair is then intersected exactly with the robot's shapes in their own frames: boxes by the
slab test, convex meshes by their face planes, spheres, cylinders and capsules by sim/raycast_exact.py. A ray
that starts inside a shape does not see it (as in Bullet and the Embree path).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from sim import raycast_exact as exact
from sim.raycast_shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape

CLOSED_FORM = (BOX, MESH, SPHERE, CYLINDER, CAPSULE)  # kinds intersected here; others go to an Embree build
EVEN_TOL = 1e-7  # rad: headings this close to an even spacing count as evenly spaced (intervals widen by it)
RUN_BREAK = 0.25  # m: consecutive rays whose origins are farther apart start a new group
TWO_PI = 2 * np.pi


@dataclass(frozen=True)
class ShapeForm:
    """One shape of a robot template, ready for closed-form tests: world → shape frame is inv_local ∘
    inverse base pose."""

    kind: int
    inv_local: np.ndarray  # 4×4: base frame → shape frame
    radius: float
    half_length: float
    half: np.ndarray  # box half extents (shape frame)
    planes: np.ndarray  # convex mesh: (F, 4) outward unit normal and offset, inside where n·x + c ≤ 0
    plan_radius: float  # farthest point of the shape from the base's z axis
    z_range: tuple[float, float]  # in the base frame
    reach: float  # farthest point of the shape from the base's origin (any orientation)
    own_reach: float  # farthest point of the shape from its own frame's origin

    @cached_property
    def own_frame(self) -> tuple[np.ndarray, ShapeForm]:
        """The shape's frame in its body's (the inverse of inv_local) and this form in its own frame (inv_local
        the identity): cast_posed needs both every cast, so they are made once per form."""
        return np.linalg.inv(self.inv_local), replace(self, inv_local=np.eye(4))


def shape_form(s: Shape) -> ShapeForm:
    pts = s.verts @ s.local[:3, :3].T + s.local[:3, 3]
    half = np.abs(s.verts).max(axis=0) if s.kind == BOX else np.zeros(3)
    planes = ConvexHull(s.verts).equations if s.kind == MESH else np.zeros((0, 4))
    return ShapeForm(s.kind, np.linalg.inv(s.local), float(s.radius), float(s.half_length), half, planes,
                     float(np.hypot(pts[:, 0], pts[:, 1]).max()), s.z_range, float(np.linalg.norm(pts, axis=1).max()),
                     float(np.linalg.norm(s.verts, axis=1).max()))


def supported(shapes: list[Shape]) -> bool:
    return all(s.kind in CLOSED_FORM for s in shapes)


def _box(o: np.ndarray, d: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Entry t of the slab test for the box |x| ≤ half; inf for a miss or a start inside."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1, t2 = (-half - o) * inv, (half - o) * inv
    flat = d == 0  # parallel to a slab: no bound from it, and a miss when it runs outside that slab
    enter = np.where(flat, -np.inf, np.minimum(t1, t2)).max(axis=1)
    leave = np.where(flat, np.inf, np.maximum(t1, t2)).min(axis=1)
    ok = ~(flat & (np.abs(o) > half)).any(axis=1) & (enter <= leave) & (enter >= 0)
    return np.where(ok, enter, np.inf)


def _convex(o: np.ndarray, d: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """Entry t through the face planes of a convex polyhedron; inf for a miss or a start inside."""
    dist = o @ planes[:, :3].T + planes[:, 3]  # (P, F): > 0 outside that face
    rate = d @ planes[:, :3].T
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -dist / rate
    enter = np.where(rate < 0, t, -np.inf).max(axis=1)
    leave = np.where(rate > 0, t, np.inf).min(axis=1)
    miss = ((rate == 0) & (dist > 0)).any(axis=1) | ~(dist > 0).any(axis=1)
    return np.where(~miss & (enter <= leave) & (enter >= 0), enter, np.inf)


def _shape_t(f: ShapeForm, lo: np.ndarray, ld: np.ndarray) -> np.ndarray:
    if f.kind == BOX:
        return _box(lo, ld, f.half)
    if f.kind == MESH:
        return _convex(lo, ld, f.planes)
    r, h = f.radius, f.half_length
    if f.kind == SPHERE:
        return exact.sphere(lo, ld, r)
    return exact.cylinder(lo, ld, r, h) if f.kind == CYLINDER else exact.capsule(lo, ld, r, h)


@dataclass
class RayGroups:
    """Rays sorted by (group, heading), shared by every robot group of one cast. A group is a run of
    consecutive rays whose origins are close (a lidar's beams, as World.cast_rays gets them)."""

    order: np.ndarray  # ray indices in sorted order
    keys: np.ndarray  # sorted group * 8 + heading in [0, 2π) counted from the group's `ref`
    ref: np.ndarray  # (G,) heading of the group's first ray
    centre: np.ndarray  # (G, 2) mean origin
    spread: np.ndarray  # (G,) farthest origin from the centre
    offset: np.ndarray  # (G,) farthest ray line from the centre (~0 for a lidar's beams: they share a centre)
    outward: np.ndarray  # (G,) least (origin − centre)·heading: how far every ray starts out past the centre
    reach: float  # longest horizontal extent of any ray
    first: np.ndarray  # (G,) position of the group's first ray in `keys`
    count: np.ndarray  # (G,)
    step: np.ndarray  # (G,) heading step of a group whose rays are evenly spaced in heading (a lidar), else 0


def group_rays(o: np.ndarray, d: np.ndarray) -> RayGroups:
    ox, oy, dx, dy = (np.ascontiguousarray(a) for a in (o[:, 0], o[:, 1], d[:, 0], d[:, 1]))
    sx, sy = ox[1:] - ox[:-1], oy[1:] - oy[:-1]
    start = np.flatnonzero(np.concatenate([[True], sx * sx + sy * sy > RUN_BREAK * RUN_BREAK]))
    g = np.zeros(len(o), np.int64)
    g[start[1:]] = 1
    g = np.cumsum(g)
    count = np.diff(np.append(start, len(o)))
    cx, cy = np.add.reduceat(ox, start) / count, np.add.reduceat(oy, start) / count
    rx, ry = ox - cx[g], oy - cy[g]
    r2 = rx * rx + ry * ry
    length = np.sqrt(dx * dx + dy * dy)
    flat = length < 1e-12  # a vertical ray: its "line" is its origin
    inv = 1.0 / np.where(flat, 1.0, length)
    line = np.where(flat, np.sqrt(r2), np.abs(dx * ry - dy * rx) * inv)
    out = np.where(flat, -np.inf, (rx * dx + ry * dy) * inv)
    heading = np.arctan2(dy, dx)
    ref = heading[start]  # headings count from the group's first ray: a lidar's beams are then in order
    keys = g * 8.0 + (heading - ref[g]) % TWO_PI
    step = np.zeros(len(start))
    first = start
    if np.all(keys[1:] >= keys[:-1]):
        order = np.arange(len(o))
        # Evenly spaced headings (a lidar's beams): a heading interval maps to indices without a search.
        many = count > 1
        step[many] = keys[start[many] + 1] - keys[start[many]]
        local = keys - g * 8.0 - (np.arange(len(o)) - start[g]) * step[g]
        step[np.maximum.reduceat(np.abs(local), start) > EVEN_TOL] = 0.0
    else:
        order = np.argsort(keys, kind="stable")
        keys = keys[order]
        first = np.searchsorted(keys, np.arange(len(start)) * 8.0)  # groups keep their rays, now by heading
    return RayGroups(order, keys, ref, np.column_stack([cx, cy]), np.sqrt(np.maximum.reduceat(r2, start)),
                     np.maximum.reduceat(line, start), np.minimum.reduceat(out, start), float(length.max()),
                     first, count, step)


def _ranges(rg: RayGroups, gi: np.ndarray, a0: np.ndarray, a1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions [start, end) in `rg.keys` of group gi's rays with local heading in [a0, a1] (a superset)."""
    step, first, count = rg.step[gi], rg.first[gi], rg.count[gi]
    even = step > 0
    safe = np.where(even, step, 1.0)
    lo = first + np.clip(np.ceil((a0 - EVEN_TOL) / safe), 0, count).astype(np.int64)
    hi = first + np.clip(np.floor((a1 + EVEN_TOL) / safe) + 1, 0, count).astype(np.int64)
    odd = np.flatnonzero(~even)
    if odd.size:
        base = gi[odd] * 8.0
        lo[odd] = np.searchsorted(rg.keys, base + a0[odd], side="left")
        hi[odd] = np.searchsorted(rg.keys, base + a1[odd], side="right")
    return lo, hi


def _pairs(rg: RayGroups, xy: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """(ray index, robot index) of every ray that could pass within `rho` of a robot centre in `xy`.

    For a group (centre C, origins within h of C, ray lines within δ of C) and a robot at distance D > ρ + h:
    a ray's heading is within asin((ρ + h) / D) < 90° of the bearing C → robot (the cone of the two discs),
    and its line passes within ρ of the robot only if D |sin Δ| ≤ ρ + δ; so |Δ| ≤ asin((ρ + min(h, δ)) / D)."""
    pad = float(rg.spread.max()) + rho + 1e-6
    gi, rj = _near(rg.centre, xy, rg.reach + pad)
    if gi.size == 0:
        return gi, rj
    v = xy.take(rj, axis=0) - rg.centre.take(gi, axis=0)  # .take: a[idx]'s rows, ~4x faster
    dist = np.hypot(v[:, 0], v[:, 1])
    h = rg.spread[gi]
    # Out of reach, or behind every ray of the group (each starts farther out along its heading than the
    # robot's disc reaches: a lidar and its own robot).
    keep = (dist <= rg.reach + h + rho + 1e-6) & (rg.outward[gi] <= dist + rho + 1e-6)
    gi, rj, v, dist, h = gi[keep], rj[keep], np.compress(keep, v, axis=0), dist[keep], h[keep]
    near = dist <= h + rho + 1e-6  # the robot overlaps the group's disc: every heading
    width = rho + np.minimum(h, rg.offset[gi]) + 1e-6
    with np.errstate(invalid="ignore", divide="ignore"):
        half = np.where(near, np.pi, np.arcsin(np.clip(width / np.where(near, 1.0, dist), 0.0, 1.0)))
    mid = (np.arctan2(v[:, 1], v[:, 0]) - rg.ref[gi]) % TWO_PI
    lo, hi = mid - half, mid + half
    # The heading interval, cut at 0 / 2π into a main part and (rarely) a wrapped part.
    a0 = np.where(near, 0.0, np.clip(lo, 0.0, TWO_PI))
    a1 = np.where(near, TWO_PI, np.clip(hi, 0.0, TWO_PI))
    wrap = np.flatnonzero(~near & ((lo < 0) | (hi > TWO_PI)))
    lo_w, hi_w = lo[wrap], hi[wrap]
    w0 = np.where(lo_w < 0, lo_w + TWO_PI, 0.0)
    w1 = np.where(lo_w < 0, TWO_PI, hi_w - TWO_PI)
    starts, ends = _ranges(rg, np.concatenate([gi, gi[wrap]]), np.concatenate([a0, w0]), np.concatenate([a1, w1]))
    robots = np.concatenate([rj, rj[wrap]])
    counts = np.maximum(ends - starts, 0)
    total = int(counts.sum())
    if total == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pos = np.repeat(starts - np.cumsum(counts) + counts, counts) + np.arange(total)
    return rg.order[pos], np.repeat(robots, counts)


def _near(a: np.ndarray, b: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i into a, j into b) with |a_i − b_j| ≤ r."""
    if len(a) * len(b) <= 50_000:
        dx = a[:, None, 0] - b[None, :, 0]
        dy = a[:, None, 1] - b[None, :, 1]
        i, j = np.nonzero(dx * dx + dy * dy <= r * r)
        return i, j
    m = cKDTree(a).sparse_distance_matrix(cKDTree(b), r, output_type="ndarray")
    return m["i"].astype(np.int64), m["j"].astype(np.int64)


def cast_upright(rg: RayGroups, o: np.ndarray, d: np.ndarray, forms: list[ShapeForm], pose: np.ndarray,
                 uid: np.ndarray, z_band: tuple[float, float], best: np.ndarray, best_uid: np.ndarray) -> None:
    """Lower `best` (t in units of d) and set `best_uid` where a ray meets one of these robots first. `pose` is
    (B, 3) x, y, yaw of robots sharing the shape list `forms`; `uid` their body uids."""
    forms = [f for f in forms if f.z_range[1] >= z_band[0] and f.z_range[0] <= z_band[1]]
    if not forms or len(pose) == 0:
        return
    c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
    inv = np.zeros((len(pose), 3, 4))  # world → base: the transpose rotation, then minus the rotated position
    inv[:, 0, 0], inv[:, 0, 1], inv[:, 1, 0], inv[:, 1, 1], inv[:, 2, 2] = c, s, -s, c, 1.0
    inv[:, 0, 3] = -(c * pose[:, 0] + s * pose[:, 1])
    inv[:, 1, 3] = s * pose[:, 0] - c * pose[:, 1]
    cast_bodies(rg, o, d, forms, inv, pose[:, :2], max(f.plan_radius for f in forms), uid, best, best_uid)


def cast_posed(rg: RayGroups, o: np.ndarray, d: np.ndarray, forms: list[ShapeForm], frames: np.ndarray,
               uid: np.ndarray, z_band: tuple[float, float], best: np.ndarray, best_uid: np.ndarray) -> None:
    """cast_upright for bodies in any orientation: `frames` (B, 4, 4) world ← body (a link's pose read from the
    engine). Shape by shape: each counts by the sphere about its own frame holding it, whose plan is a disc,
    and only where that sphere reaches the rays' heights (a lidar's rays miss a robot's chassis and mast)."""
    for f in forms:
        local, own = f.own_frame
        shape = frames @ local  # world ← shape frame
        z = shape[:, 2, 3]
        keep = np.flatnonzero((z + f.own_reach >= z_band[0]) & (z - f.own_reach <= z_band[1]))
        if keep.size == 0:
            continue
        shape = shape[keep]
        rt = shape[:, :3, :3].transpose(0, 2, 1)
        inv = np.concatenate([rt, -np.einsum("bij,bj->bi", rt, shape[:, :3, 3])[:, :, None]], axis=2)
        cast_bodies(rg, o, d, [own], inv, shape[:, :2, 3], f.own_reach, uid[keep], best, best_uid)



def cast_bodies(rg: RayGroups, o: np.ndarray, d: np.ndarray, forms: list[ShapeForm], inv: np.ndarray,
                xy: np.ndarray, rho: float, uid: np.ndarray, best: np.ndarray, best_uid: np.ndarray) -> None:
    """The rays' nearest hits on bodies sharing the shapes `forms`: `inv` (B, 3, 4) world → body, `xy` (B, 2)
    where each body's shapes lie within `rho` in the plan."""
    ray, rob = _pairs(rg, xy, rho)
    if rg.offset.any():
        # Exactly: keep the pairs whose segment passes within ρ of the body's axis (in the plan). Not for
        # groups whose ray lines all pass through their centre (a lidar's fans): _pairs' heading intervals
        # are then already that tight, and the shape tests below are exact either way.
        dx, dy = d[ray, 0], d[ray, 1]
        rx, ry = xy[rob, 0] - o[ray, 0], xy[rob, 1] - o[ray, 1]
        dd = dx * dx + dy * dy
        u = np.clip((rx * dx + ry * dy) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
        ex, ey = rx - u * dx, ry - u * dy
        close = np.flatnonzero(ex * ex + ey * ey <= (rho + 1e-6) ** 2)
        ray, rob = ray[close], rob[close]
    if ray.size == 0:
        return
    m = inv.reshape(len(inv), 12).take(rob, axis=0)  # .take: the same rows as inv[rob], ~4x faster
    bo, bd = _apply(m, o.take(ray, axis=0), True), _apply(m, d.take(ray, axis=0), False)
    t = np.full(ray.size, np.inf)
    for f in forms:
        m = f.inv_local
        t = np.minimum(t, _shape_t(f, bo @ m[:3, :3].T + m[:3, 3], bd @ m[:3, :3].T))
    hit = np.flatnonzero(t < best[ray])
    if hit.size == 0:
        return
    ray, t, rob = ray[hit], t[hit], rob[hit]
    np.minimum.at(best, ray, t)  # per ray, its nearest body (a ray may reach several)
    won = t == best[ray]
    best_uid[ray[won]] = uid[rob[won]]


def _apply(m: np.ndarray, v: np.ndarray, shift: bool) -> np.ndarray:
    """(P, 3): the pairs' matrices m (P, 12; entry (i, j) at 4i + j) applied to the vectors v (P, 3) as
    (m_i0 v_0 + m_i1 v_1) + m_i2 v_2 (+ m_i3 with `shift`), one component at a time over all pairs: a
    (P, 3, 4) broadcast runs numpy's inner loop three elements at a time, and a batched einsum is slower still."""
    out = np.empty((len(v), 3))
    for i in range(3):
        r = m[:, 4 * i] * v[:, 0]
        r += m[:, 4 * i + 1] * v[:, 1]
        r += m[:, 4 * i + 2] * v[:, 2]
        if shift:
            r += m[:, 4 * i + 3]
        out[:, i] = r
    return out
