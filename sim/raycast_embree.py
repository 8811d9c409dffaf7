"""Ray casting for fleets through Intel Embree (`embreex`): static geometry in one BVH built once per model
version; upright robots (kinematic, posed by the robot table) intersected in closed form per (ray, robot) pair
(sim/raycast_robots.py), so robots that moved need no rebuild; bodies moved by physics (dynamic robots,
movable models) in a small scene rebuilt per cast from their link poses.

Boxes, meshes and planes are exact triangles; cylinders, spheres and capsules are enclosing proxies whose hits
are refined analytically (sim/raycast_exact.py) in float64. A ray that passes a proxy without touching the
shape, or meets the back of a convex shape, continues from just past that hit. The same (fraction, uid)
contract as PyBullet's rayTestBatch (World.cast_rays), so either backend can serve the lidar.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sim import raycast_exact as exact
from sim import raycast_robots as robots
from sim.raycast_shapes import BOX, CAPSULE, CYLINDER, MESH, SPHERE, Shape, body_shapes, link_matrix
from sim.types import Mesh

if TYPE_CHECKING:
    from sim.world import World

MAX_PASSES = 8  # continuations per ray (a ray crossing a proxy needs two)
REACH_CELL = 1.0  # m: ray origins are binned in cells this size to find the robots the rays can reach
MAX_REACH_TESTS = 100_000  # cells × robots above which robots are not culled
STEP_M = 2e-5  # m: how far past a passed-through surface a continued ray starts (> float32 spacing at 100 m)


def _embree() -> tuple[Any, Any]:
    import embreex.mesh_construction as mc
    import embreex.rtcore_scene as rs

    return rs, mc


@dataclass
class _Geometry:
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


Part = tuple[list[Shape], np.ndarray, np.ndarray]  # shapes shared by B bodies, base matrices (B, 4, 4), uids (B,)


def _build(parts: list[Part], z_band: tuple[float, float] | None = None) -> _Geometry | None:
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
    return _Geometry(None, None, np.concatenate(verts), np.concatenate(faces), np.concatenate(prim),
                     np.concatenate(kind), np.concatenate(uid).astype(np.int64), np.concatenate(radius).astype(float),
                     np.concatenate(half).astype(float), np.linalg.inv(np.concatenate(frames)))


def _commit(parts: Sequence[_Geometry | None]) -> _Geometry | None:
    """One Embree scene over several geometries (their arrays concatenated)."""
    gs = [g for g in parts if g is not None]
    if not gs:
        return None
    if len(gs) == 1:
        g = gs[0]
    else:
        v_off = np.cumsum([0] + [len(g.verts) for g in gs[:-1]])
        s_off = np.cumsum([0] + [len(g.kind) for g in gs[:-1]])
        g = _Geometry(None, None, np.concatenate([g.verts for g in gs]),
                      np.concatenate([g.faces + o for g, o in zip(gs, v_off, strict=True)]),
                      np.concatenate([g.prim_shape + o for g, o in zip(gs, s_off, strict=True)]),
                      *(np.concatenate([getattr(g, k) for g in gs]) for k in ("kind", "uid", "radius", "half", "inv")))
    if g.scene is None:
        rs, mc = _embree()
        g.scene = rs.EmbreeScene()
        g.handle = mc.TriangleMesh(g.scene, g.verts.astype(np.float32), g.faces.astype(np.int32))
    return g


def _cast(g: _Geometry, o: np.ndarray, d: np.ndarray, limit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest true hit per ray in one scene closer than `limit`: (t in units of d, inf if none; uid or -1)."""
    n = len(o)
    t_hit = np.full(n, np.inf)
    uid = np.full(n, -1, np.int64)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    res = g.scene.run(o32, d32, dists=limit.astype(np.float32), output=1)  # first pass: every ray, no copies
    active = np.flatnonzero(res["primID"] >= 0)
    prim, t_emb, ng = res["primID"][active], res["tfar"][active].astype(np.float64), res["Ng"][active]
    off = np.zeros(active.size)
    for k in range(MAX_PASSES):
        shape = g.prim_shape[prim]
        kind = g.kind[shape]
        t = t_emb.copy()
        convex = (kind == BOX) | (kind == MESH)
        if convex.any():  # the back of a convex shape met first: the ray starts inside it and, as in Bullet, goes on
            ci = np.flatnonzero(convex)
            back = np.einsum("ij,ij->i", ng[ci], d32[active[ci]]) > 0
            t[ci[back]] = np.inf
        curved = (kind >= SPHERE) & (kind <= CAPSULE)
        if curved.any():
            ci = np.flatnonzero(curved)
            sub = active[ci]
            t[ci] = _refine(g, shape[ci], kind[ci], o[sub] + off[ci, None] * d[sub], d[sub])
        done = np.isfinite(t)
        rows = active[done]
        t_hit[rows] = off[done] + t[done]
        uid[rows] = g.uid[shape[done]]
        if done.all() or k == MAX_PASSES - 1:
            break
        passed = ~done
        active, off = active[passed], off[passed] + t_emb[passed]
        off += STEP_M / np.linalg.norm(d[active], axis=1)
        keep = off < limit[active]
        active, off = active[keep], off[keep]
        if active.size == 0:
            break
        oa = (o[active] + off[:, None] * d[active]).astype(np.float32)
        res = g.scene.run(oa, d32[active], dists=(limit[active] - off).astype(np.float32), output=1)
        hit = res["primID"] >= 0
        active, off = active[hit], off[hit]
        prim, t_emb, ng = res["primID"][hit], res["tfar"][hit].astype(np.float64), res["Ng"][hit]
        if active.size == 0:
            break
    return t_hit, uid


def _refine(g: _Geometry, shape: np.ndarray, kind: np.ndarray, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    inv = g.inv[shape]
    lo = np.einsum("bij,bj->bi", inv[:, :3, :3], o) + inv[:, :3, 3]
    ld = np.einsum("bij,bj->bi", inv[:, :3, :3], d)
    r, h = g.radius[shape], g.half[shape]
    t = np.full(len(o), np.inf)
    for k, fn in ((SPHERE, None), (CYLINDER, exact.cylinder), (CAPSULE, exact.capsule)):
        m = kind == k
        if m.any():
            t[m] = exact.sphere(lo[m], ld[m], r[m]) if fn is None else fn(lo[m], ld[m], r[m], h[m])
    return t


class EmbreeCaster:
    """World.cast_rays through Embree. Holds no PyBullet state of its own: shapes are read back lazily."""

    def __init__(self, world: World) -> None:
        self.world = world
        # False: upright robots are built as triangles into a scene every cast (the approach before issue 17a,
        # kept as the benchmarks' same-run baseline and for robot shapes the closed form does not cover).
        self.closed_form = True
        self._static: _Geometry | None = None
        self._static_key: tuple[object, ...] | None = None
        self._templates: dict[tuple[int, str], list[Shape]] = {}
        self._groups: dict[bytes, list[Shape]] = {}
        self._link_templates: dict[tuple[int, str], dict[int, list[Shape]]] = {}
        self._upright: list[tuple[list[Shape], np.ndarray, float]] = []
        self._forms: dict[int, list[robots.ShapeForm]] = {}  # id(template shape list) → closed-form shapes
        self._upright_key: tuple[object, ...] | None = None

    def _mesh_table(self) -> dict[tuple[int, int], list[Mesh | None]]:
        out: dict[tuple[int, int], list[Mesh | None]] = {}
        for rec in self.world.models.records.values():
            if rec.description is None:
                continue
            by_name = {lk.name: lk for lk in rec.description.links}
            for uid, links in rec.link_names.items():
                for idx, lname in links.items():
                    lk = by_name.get(lname)
                    if lk is not None:
                        geoms = [c.geometry for c in lk.collisions if c.geometry.kind != "plane"]
                        out[(uid, idx)] = [g if isinstance(g, Mesh) else None for g in geoms]
        return out

    def _static_scene(self) -> _Geometry | None:
        models = self.world.models
        uids = sorted(u for r in models.records.values() if r.static for u in r.uids)
        key = (models.version, tuple(uids))
        if key != self._static_key:
            meshes = self._mesh_table()
            parts: list[Part] = []
            for u in uids:
                shapes = body_shapes(models.client, u, meshes)
                if shapes:
                    parts.append((shapes, link_matrix(models.client, u, -1)[None], np.array([u])))
            self._static = _commit([_build(parts)])  # its BVH is built here, once per model version
            self._static_key = key
        return self._static

    def _template(self, uid: int, label: str) -> list[Shape]:
        """Shapes of an upright body moved by this sim (kinematic robots), relative to its base, whose pose is
        the robot table's (x, y, 0, yaw): the base is teleported there every step."""
        key = (uid, label)
        if key not in self._templates:
            shapes = [Shape(-1, s.link, s.kind, s.radius, s.half_length, s.local, s.verts, s.faces)
                      for s in body_shapes(self.world.client, uid, self._mesh_table())]
            # Bodies with the same shapes (robots of one model) share one list, so they build as one group.
            sig = b"".join(np.round(np.concatenate([s.local.ravel(), s.verts.ravel(), s.faces.ravel(),
                                                    [s.kind, s.radius, s.half_length]]), 6).tobytes()
                           for s in shapes)
            self._templates[key] = self._groups.setdefault(sig, shapes)
        return self._templates[key]

    def _links(self, uid: int, label: str) -> dict[int, list[Shape]]:
        """Shapes of a body moved by physics, grouped by link, each framed relative to its link."""
        key = (uid, "links:" + label)
        if key not in self._link_templates:
            by_link: dict[int, list[Shape]] = {}
            for s in body_shapes(self.world.client, uid, self._mesh_table(), per_link=True):
                by_link.setdefault(s.link, []).append(Shape(-1, s.link, s.kind, s.radius, s.half_length, s.local,
                                                            s.verts, s.faces))
            self._link_templates[key] = by_link
        return self._link_templates[key]

    def _upright_groups(self) -> list[tuple[list[Shape], np.ndarray, float]]:
        """Kinematic robots grouped by shared shape set: (shapes, table rows, plan radius of the shapes about
        the base), cached while the robots and their bodies stay the same (the per-cast work is then numpy)."""
        w = self.world
        t = w.table
        key = (tuple(t.names), t.body.tobytes(), t.b["kinematic"].tobytes())
        if key != self._upright_key:
            groups: dict[int, tuple[list[Shape], list[int]]] = {}
            for i in np.flatnonzero(t.b["kinematic"]).tolist():
                name = t.names[i]
                shapes = self._template(int(t.body[i]), f"robot:{name}:{id(w.specs[name])}")
                groups.setdefault(id(shapes), (shapes, []))[1].append(i)
            self._upright = [(shapes, np.asarray(rows, np.int64), max(
                float(np.hypot(*(s.verts @ s.local[:2, :3].T + s.local[:2, 3]).T).max()) for s in shapes))
                for shapes, rows in groups.values() if shapes]
            self._upright_key = key
        return self._upright

    def _dynamic_scene(self, z_band: tuple[float, float], rays: tuple[np.ndarray, np.ndarray] | None = None
                       ) -> list[_Geometry]:
        """The moving bodies as geometry. With `rays` (origins, directions), kinematic robots built as triangles
        (a shape the closed form does not cover) that no ray can reach are left out (see _reach)."""
        w = self.world
        t, f = w.table, w.table.f
        kin = t.b["kinematic"]
        upright: list[Part] = []
        reach: tuple[np.ndarray, float] | None = None
        computed = False
        # When the engine steps (a dynamic robot or model exists), gravity also acts on kinematic robots between
        # teleports, so their bodies are read from PyBullet like the rest; otherwise the table is the pose.
        physics = bool((~kin).any()) or w.models.has_dynamic_models()
        if len(t) and not physics:
            for shapes, rows, plan_r in self._upright_groups():
                if self.closed_form and robots.supported(shapes):
                    continue  # cast in closed form (_closed_form_groups)
                if rays is not None and not computed:
                    reach, computed = self._reach(*rays), True
                if reach is not None:
                    cells, far = reach
                    dx = f["x"][rows][None, :] - cells[:, :1]
                    dy = f["y"][rows][None, :] - cells[:, 1:]
                    rows = rows[((dx * dx + dy * dy) <= (far + plan_r + 1e-3) ** 2).any(axis=0)]
                    if rows.size == 0:
                        continue
                c, s = np.cos(f["yaw"][rows]), np.sin(f["yaw"][rows])
                m = np.zeros((rows.size, 4, 4))
                m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1] = c, -s, s, c
                m[:, 2, 2] = m[:, 3, 3] = 1.0
                m[:, 0, 3], m[:, 1, 3] = f["x"][rows], f["y"][rows]
                upright.append((shapes, m, t.body[rows]))
        groups: dict[int, tuple[list[Shape], list[np.ndarray], list[int]]] = {}
        # Bodies moved by physics (dynamic robots, movable models): each link at its pose now, since
        # joints (casters, wheels, hinges) move links relative to the base.
        moving = [(int(t.body[i]), f"robot:{t.names[i]}:{id(w.specs[t.names[i]])}")
                  for i in (range(len(t)) if physics else np.flatnonzero(~kin))]
        moving += [(u, f"model:{rec.name}:{w.models.version}") for rec in w.models.records.values()
                   if not rec.static for u in rec.uids]
        for uid, label in moving:
            for link, shapes in self._links(uid, label).items():
                entry = groups.setdefault(id(shapes), (shapes, [], []))
                entry[1].append(link_matrix(w.client, uid, link))
                entry[2].append(uid)
        moved = [(shapes, np.stack(ms), np.asarray(us)) for shapes, ms, us in groups.values() if shapes]
        return [g for g in (_build(upright, z_band), _build(moved)) if g is not None]

    def _scenes(self, z_band: tuple[float, float], rays: tuple[np.ndarray, np.ndarray] | None = None
                ) -> list[_Geometry]:
        """The Embree scenes to cast against: the static one (its BVH from load) and, when bodies move under
        physics (or a robot has a shape the closed form does not cover), a small one of those, built now."""
        static = self._static_scene()
        moving = _commit(self._dynamic_scene(z_band, rays))
        return [g for g in (static, moving) if g is not None]

    def _closed_form_groups(self) -> list[tuple[list[robots.ShapeForm], np.ndarray]]:
        """(closed-form shapes, table rows) of the upright robots cast without a BVH; none under physics."""
        w = self.world
        t = w.table
        if not self.closed_form or not len(t) or bool((~t.b["kinematic"]).any()) or w.models.has_dynamic_models():
            return []
        out = []
        for shapes, rows, _ in self._upright_groups():
            if shapes and robots.supported(shapes):
                if id(shapes) not in self._forms:
                    self._forms[id(shapes)] = [robots.shape_form(s) for s in shapes]
                out.append((self._forms[id(shapes)], rows))
        return out

    def forget(self) -> None:
        """Drop every cached shape (bodies were removed or re-created, e.g. after a snapshot restore)."""
        self._templates.clear()
        self._groups.clear()
        self._link_templates.clear()
        self._forms.clear()
        self._static_key = self._upright_key = None

    def _reach(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, float] | None:
        """Where the rays can go, for culling robots: the centres of the REACH_CELL cells holding the ray
        origins and the farthest any ray point gets from its cell's centre. None (no culling) when the rays
        start all over the fleet (every lidar due at once): the distance test would cost more than it saves."""
        ij = np.floor(o[:, :2] / REACH_CELL).astype(np.int64) + (1 << 30)
        keys = np.unique(ij[:, 0] << 32 | ij[:, 1])  # one int per cell: a 1-D unique is ~10× a row-wise one
        if keys.size * max(1, len(self.world.table)) > MAX_REACH_TESTS:
            return None
        cells = np.stack([keys >> 32, keys & 0xFFFFFFFF], axis=1) - (1 << 30)
        far = float(np.sqrt(np.einsum("ij,ij->i", d, d).max())) + REACH_CELL * 0.7072
        return (cells + 0.5) * REACH_CELL, far

    def cast(self, origins: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        o = np.asarray(origins, np.float64).reshape(-1, 3)
        d = np.asarray(ends, np.float64).reshape(-1, 3) - o
        best = np.full(len(o), np.inf)
        uids = np.full(len(o), -1, np.int64)
        if len(o) == 0:
            return np.ones(0), np.full(0, -1, np.int64)
        z = np.concatenate([o[:, 2], o[:, 2] + d[:, 2]])
        z_band = (float(z.min()), float(z.max()))
        groups = self._closed_form_groups()
        if groups:  # robots first: their hits shorten the rays the BVH traverses
            t = self.world.table
            rg = robots.group_rays(o, d)
            pose = np.column_stack([t.f["x"], t.f["y"], t.f["yaw"]])
            for forms, rows in groups:
                robots.cast_upright(rg, o, d, forms, pose[rows], t.body[rows], z_band, best, uids)
        for g in self._scenes(z_band, (o, d)):
            t_g, u = _cast(g, o, d, np.minimum(best, 1.0))  # a later scene only looks closer than the hits so far
            nearer = t_g < best
            best[nearer], uids[nearer] = t_g[nearer], u[nearer]
        hit = np.isfinite(best) & (best <= 1.0)
        return np.where(hit, best, 1.0), np.where(hit, uids, -1)


__all__ = ["EmbreeCaster"]
