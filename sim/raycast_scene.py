"""Embree scenes of ray-casting geometry and the cast through them (sim/raycast_embree.py decides which bodies
go into which scene): triangles in world coordinates, a shape index per triangle, and per shape its kind, body
uid and world → shape frame for the closed-form refinement of curved shapes.

Boxes, meshes and planes are exact triangles; cylinders, spheres and capsules are enclosing proxies whose hits
are refined analytically (sim/raycast_exact.py) in float64. A ray that passes a proxy without touching the
shape, or meets the back of a convex shape, continues from just past that hit.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np

from sim import raycast_exact as exact
from sim.raycast_scratch import Scratch
from sim.raycast_shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape

MAX_PASSES = 8  # continuations per ray (a ray crossing a proxy needs two)
STEP_M = 2e-5  # m: how far past a passed-through surface a continued ray starts (> float32 spacing at 100 m)
THREADS = min(4, os.cpu_count() or 1)  # embreex releases the GIL while it traverses: big casts run in chunks
# Rays per chunk below which one thread does it all: a hand-off costs ~20 µs idle, and on a loaded machine the
# second thread waits for a core (100 robots × 90 beams, 9,000 rays: no gain at load 4, so it is not split).
CHUNK_MIN = 16384
SPLIT_GAIN = 0.1  # a split cast must take at least this much less than one thread would, or the next
PROBE_EVERY = 64  # big casts stay on one thread
FLAT, CONVEX, CURVED, MISS = range(4)  # what a first-pass hit needs: nothing, a back-face test, a refinement
_pool: ThreadPoolExecutor | None = None


def _embree() -> tuple[Any, Any]:
    import embreex.mesh_construction as mc
    import embreex.rtcore_scene as rs

    return rs, mc


@dataclass
class Geometry:
    """One Embree scene and what its primitives are, in world coordinates."""

    scene: Any
    handle: Any
    verts: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (T, 3), wound outward for convex kinds
    prim_shape: np.ndarray  # (T,) shape index
    kind: np.ndarray  # per shape
    uid: np.ndarray
    radius: np.ndarray
    half: np.ndarray
    inv: np.ndarray  # (S, 4, 4) world → shape frame
    convex: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # (T,) of a convex shape: by commit
    # Per triangle, with one more entry at the end for primID −1 (a miss indexes it): FLAT / CONVEX / CURVED /
    # MISS, and the body uid (−1 for a miss). By commit.
    tri_class: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    tri_uid: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


Part = tuple[list[Shape], np.ndarray, np.ndarray]  # shapes shared by B bodies, base matrices (B, 4, 4), uids (B,)


def build(parts: list[Part], z_band: tuple[float, float] | None = None) -> Geometry | None:
    """A scene from groups of bodies sharing one shape set. Shape index order is group by group,
    body-major. With `z_band` (bases that only turn about z), shapes entirely above or below it are left out:
    no ray of this cast can reach them."""
    verts, faces, prim, frames, kind, uid, radius, half = [], [], [], [], [], [], [], []
    n_verts = start = 0
    for shapes, bases, uids in parts:
        if z_band is not None:
            shapes = [s for s in shapes if s.z_range[1] >= z_band[0] and s.z_range[0] <= z_band[1]]
        n_s, n_b = len(shapes), len(bases)
        if n_s == 0 or n_b == 0:
            continue
        for j, s in enumerate(shapes):
            frame = bases @ s.local  # (B, 4, 4)
            pts = np.matmul(s.verts[None], frame[:, :3, :3].transpose(0, 2, 1)) + frame[:, None, :3, 3]
            verts.append(pts.reshape(-1, 3))
            v = len(s.verts)
            faces.append((s.faces[None] + (n_verts + v * np.arange(n_b))[:, None, None]).reshape(-1, 3))
            n_verts += v * n_b
            prim.append(np.repeat(start + np.arange(n_b) * n_s + j, len(s.faces)))
        frames.append(np.stack([bases @ s.local for s in shapes], axis=1).reshape(-1, 4, 4))
        kind.append(np.tile([s.kind for s in shapes], n_b))
        uid.append(np.repeat(uids, n_s))
        radius.append(np.tile([s.radius for s in shapes], n_b))
        half.append(np.tile([s.half_length for s in shapes], n_b))
        start += n_s * n_b
    if start == 0:
        return None
    return Geometry(None, None, np.concatenate(verts), np.concatenate(faces), np.concatenate(prim),
                    np.concatenate(kind), np.concatenate(uid).astype(np.int64), np.concatenate(radius).astype(float),
                    np.concatenate(half).astype(float), np.linalg.inv(np.concatenate(frames)))


def commit(parts: Sequence[Geometry | None]) -> Geometry | None:
    """One Embree scene over several geometries (their arrays concatenated)."""
    gs = [g for g in parts if g is not None]
    if not gs:
        return None
    if len(gs) == 1:
        g = gs[0]
    else:
        v_off = np.cumsum([0] + [len(g.verts) for g in gs[:-1]])
        s_off = np.cumsum([0] + [len(g.kind) for g in gs[:-1]])
        g = Geometry(None, None, np.concatenate([g.verts for g in gs]),
                     np.concatenate([g.faces + o for g, o in zip(gs, v_off, strict=True)]),
                     np.concatenate([g.prim_shape + o for g, o in zip(gs, s_off, strict=True)]),
                     *(np.concatenate([getattr(g, k) for g in gs]) for k in ("kind", "uid", "radius", "half", "inv")))
    if g.scene is None:
        rs, mc = _embree()
        g.scene = rs.EmbreeScene()
        g.handle = mc.TriangleMesh(g.scene, g.verts.astype(np.float32), g.faces.astype(np.int32))
        g.convex = np.isin(g.kind[g.prim_shape], (BOX, MESH))
        tri_kind = g.kind[g.prim_shape]
        cls = np.where(g.convex, CONVEX, np.where((tri_kind >= SPHERE) & (tri_kind <= CAPSULE), CURVED, FLAT))
        g.tri_class = np.append(cls, MISS).astype(np.int8)
        g.tri_uid = np.append(g.uid[g.prim_shape], -1).astype(np.int64)
        # The first run commits the scene (builds the BVH): done here, once, before threads share the scene.
        g.scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    return g


class SplitPolicy:
    """Whether a big batch is split over threads: only while splitting pays. On a busy machine the worker waits
    for a core (and the main thread then for the GIL it took), and a split cast takes longer than one thread
    would. Each split cast is timed against k times the main thread's own chunk (what one thread would take);
    after one that saved less than SPLIT_GAIN, the next PROBE_EVERY big casts stay on one thread, then the
    split is tried again. The rays' results do not depend on it."""

    def __init__(self) -> None:
        self.skip = 0
        self.split = self.single = 0  # big casts so far, split / kept on one thread

    def use_split(self) -> bool:
        if self.skip > 0:
            self.skip -= 1
            self.single += 1
            return False
        self.split += 1
        return True

    def record(self, own_s: float, total_s: float, k: int) -> None:
        """One split cast: the main thread's chunk took own_s, the whole cast (hand-off to results) total_s."""
        if total_s > (1.0 - SPLIT_GAIN) * k * own_s:
            self.skip = PROBE_EVERY


_split = SplitPolicy()


def _run(g: Geometry, o32: np.ndarray, d32: np.ndarray, l32: np.ndarray) -> tuple[np.ndarray, ...]:
    """Embree's nearest triangle per ray: (primID, tfar, Ng); tfar is `l32` itself (Embree writes the hit
    distances over the limits, in place). Big batches are split over THREADS threads while that pays
    (SplitPolicy; the traversal runs without the GIL, and a committed Embree scene is safe to share)."""
    n = len(o32)
    k = min(THREADS, n // CHUNK_MIN)
    if k < 2 or not _split.use_split():
        res = g.scene.run(o32, d32, dists=l32, output=1)
        return res["primID"], l32, res["Ng"]
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(THREADS - 1, thread_name_prefix="embree")
    cuts = np.linspace(0, n, k + 1).astype(int)
    start = time.perf_counter()
    jobs = [_pool.submit(g.scene.run, o32[a:b], d32[a:b], dists=l32[a:b], output=1)
            for a, b in pairwise(cuts[1:])]
    own = time.perf_counter()
    parts = [g.scene.run(o32[:cuts[1]], d32[:cuts[1]], dists=l32[:cuts[1]], output=1)]
    own = time.perf_counter() - own
    parts += [j.result() for j in jobs]
    _split.record(own, time.perf_counter() - start, k)
    return (np.concatenate([r["primID"] for r in parts]), l32, np.concatenate([r["Ng"] for r in parts]))


def cast(g: Geometry, o: np.ndarray, d: np.ndarray, limit: np.ndarray, scratch: Scratch | None = None
         ) -> tuple[np.ndarray, np.ndarray]:
    """Nearest true hit per ray in one scene closer than `limit`: (t in units of d, inf if none; uid or -1).
    With `scratch`, the work arrays and the two results are its arrays (valid until its next use).

    The first pass settles most rays over whole arrays (no gathers): a miss, or a hit on a flat triangle or on
    the front of a convex shape, is final. Only the few rays that met a curved shape's proxy or the back of a
    convex shape go on through _continue."""
    s = Scratch() if scratch is None else scratch
    n = len(o)
    o32, d32, l32 = s.get("o32", n, np.float32, 3), s.get("d32", n, np.float32, 3), s.get("l32", n, np.float32)
    for buf, src in ((o32, o), (d32, d), (l32, limit)):
        np.copyto(buf, src, casting="same_kind")  # = astype(float32), into the kept array
    prim, t32, ng = _run(g, o32, d32, l32)  # first pass: every ray
    cls = np.take(g.tri_class, prim, out=s.get("cls", n, np.int8), mode="wrap")  # primID −1 (a miss): MISS
    # The back of a convex shape met first: the ray starts inside it and, as in Bullet, goes on. The dot
    # product is Ng·d as (x·x + y·y) + z·z in float32, term by term into kept arrays.
    dot, term = s.get("dot", n, np.float32), s.get("term", n, np.float32)
    np.multiply(ng[:, 0], d32[:, 0], out=dot)
    dot += np.multiply(ng[:, 1], d32[:, 1], out=term)
    dot += np.multiply(ng[:, 2], d32[:, 2], out=term)
    back, other = s.get("back", n, np.bool_), s.get("other", n, np.bool_)
    np.greater(dot, 0, out=back)
    back &= np.equal(cls, CONVEX, out=other)
    not_final = np.greater(cls, CONVEX, out=other)  # curved, or a miss
    not_final |= back
    t_hit, uid = s.get("t_hit", n, np.float64), s.get("uid", n, np.int64)
    np.copyto(t_hit, t32)
    np.copyto(t_hit, np.inf, where=not_final)
    np.take(g.tri_uid, prim, out=uid, mode="wrap")
    np.copyto(uid, -1, where=not_final)
    not_final &= np.not_equal(cls, MISS, out=back)
    more = np.flatnonzero(not_final)
    if more.size:
        _continue(g, o, d, d32, limit, more, prim[more], t32[more].astype(np.float64), ng.take(more, axis=0),
                  t_hit, uid)
    return t_hit, uid


def _continue(g: Geometry, o: np.ndarray, d: np.ndarray, d32: np.ndarray, limit: np.ndarray, active: np.ndarray,
              prim: np.ndarray, t_emb: np.ndarray, ng: np.ndarray, t_hit: np.ndarray, uid: np.ndarray) -> None:
    """The rays `active` whose first-pass hit (prim, t_emb, ng) is not final: curved proxies are refined
    analytically, and rays that passed a proxy or met a back face are cast again from just past that hit."""
    off = np.zeros(active.size)
    for k in range(MAX_PASSES):
        shape = g.prim_shape[prim]
        kind = g.kind[shape]
        t = t_emb.copy()
        # The back of a convex shape met first: the ray starts inside it and, as in Bullet, goes on.
        da = d32.take(active, axis=0)
        back = g.convex[prim] & (ng[:, 0] * da[:, 0] + ng[:, 1] * da[:, 1] + ng[:, 2] * da[:, 2] > 0)
        t[back] = np.inf
        curved = (kind >= SPHERE) & (kind <= CAPSULE)
        if curved.any():
            ci = np.flatnonzero(curved)
            sub = active[ci]
            ds = d.take(sub, axis=0)
            t[ci] = _refine(g, shape[ci], kind[ci], o.take(sub, axis=0) + off[ci, None] * ds, ds)
        done = np.isfinite(t)
        rows = active[done]
        t_hit[rows] = off[done] + t[done]
        uid[rows] = g.uid[shape[done]]
        if done.all() or k == MAX_PASSES - 1:
            break
        passed = ~done
        active, off = active[passed], off[passed] + t_emb[passed]
        off += STEP_M / np.linalg.norm(d.take(active, axis=0), axis=1)
        keep = off < limit[active]
        active, off = active[keep], off[keep]
        if active.size == 0:
            break
        oa = (o.take(active, axis=0) + off[:, None] * d.take(active, axis=0)).astype(np.float32)
        prim, t32, ng = _run(g, oa, d32.take(active, axis=0), (limit[active] - off).astype(np.float32))
        hit = prim >= 0
        active, off = active[hit], off[hit]
        prim, t_emb, ng = prim[hit], t32[hit].astype(np.float64), np.compress(hit, ng, axis=0)
        if active.size == 0:
            break


def _refine(g: Geometry, shape: np.ndarray, kind: np.ndarray, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    inv = g.inv.take(shape, axis=0)
    lo = np.einsum("bij,bj->bi", inv[:, :3, :3], o) + inv[:, :3, 3]
    ld = np.einsum("bij,bj->bi", inv[:, :3, :3], d)
    r, h = g.radius[shape], g.half[shape]
    t = np.full(len(o), np.inf)
    for k, fn in ((SPHERE, None), (CYLINDER, exact.cylinder), (CAPSULE, exact.capsule)):
        m = kind == k
        if m.any():
            t[m] = exact.sphere(lo[m], ld[m], r[m]) if fn is None else fn(lo[m], ld[m], r[m], h[m])
    return t


__all__ = ["Geometry", "Part", "build", "cast", "commit"]
