"""Ray casting for fleets through Intel Embree (`embreex`): static geometry in one BVH built once per model
version (sim/raycast_scene.py); every moving body intersected in closed form per (ray, body) pair at its
current pose (sim/raycast_robots.py), so nothing that moved needs a rebuild: upright robots (kinematic, posed by
the robot table) by their (x, y, yaw), and bodies moved by physics (movable models, dynamic robots) link by
link at the poses read from PyBullet. Only a moving shape the closed form does not cover (a concave mesh) goes
into a small Embree scene built per cast.

The same (fraction, uid) contract as PyBullet's rayTestBatch (World.cast_rays), so either backend can serve
the lidar. A lidar's ray layout (sim/raycast_layout.py) gives the ray groups the closed form needs directly;
bare rays get them from sim/raycast_robots.py group_rays.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from sim import raycast_robots as robots
from sim import raycast_scene as scene
from sim.raycast_fans import FanCache
from sim.raycast_layout import RayLayout, layout_groups
from sim.raycast_scene import Geometry, Part
from sim.raycast_scratch import Scratch
from sim.raycast_shapes import Shape, body_shapes, link_matrix, link_pose, pose_matrices
from sim.types import Mesh

if TYPE_CHECKING:
    from sim.world import World

REACH_CELL = 1.0  # m: ray origins are binned in cells this size to find the robots the rays can reach
MAX_REACH_TESTS = 100_000  # cells × robots above which robots are not culled
Moving = tuple[list[Shape], np.ndarray, np.ndarray]  # link shapes shared by B links, their poses (B, 4, 4), uids


class EmbreeCaster:
    """World.cast_rays through Embree. Holds no PyBullet state of its own: shapes are read back lazily."""

    def __init__(self, world: World) -> None:
        self.world = world
        # False: every moving body (robots, movable models) is built as triangles into a scene every cast (the
        # approach before issues 17a/17c, kept as the benchmarks' same-run baseline and for the shapes the closed
        # form does not cover).
        self.closed_form = True
        self._static: Geometry | None = None
        self._static_key: int | None = None  # the models' static_version the static scene was built at
        self._templates: dict[tuple[int, str], list[Shape]] = {}
        self._groups: dict[bytes, list[Shape]] = {}
        self._link_templates: dict[tuple[int, str], dict[int, list[Shape]]] = {}
        self._upright: list[tuple[list[Shape], np.ndarray, float]] = []
        self._forms: dict[int, list[robots.ShapeForm]] = {}  # id(shared shape list) → closed-form shapes
        self._upright_key: tuple[object, ...] | None = None
        self._moving_key: tuple[object, ...] | None = None
        self._moving_links: list[tuple[int, int]] = []  # (uid, link) whose poses _moving reads, in order
        self._moving_groups: list[tuple[list[Shape], np.ndarray, np.ndarray]] = []  # shapes, rows, uids
        # Static-scene hits of lidar fans whose rays repeat exactly (robots standing still); None: always cast
        self.fans: FanCache | None = FanCache()
        self._scratch = Scratch()  # the cast's full-length work arrays, reused (sim/raycast_scratch.py)
        self._lock = threading.Lock()

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

    def _static_scene(self) -> Geometry | None:
        models = self.world.models
        # static_version, not version: moving a movable model must not rebuild the static BVH
        if models.static_version != self._static_key:
            meshes = self._mesh_table()
            parts: list[Part] = []
            for u in sorted(u for r in models.records.values() if r.static for u in r.uids):
                shapes = body_shapes(models.client, u, meshes)
                if shapes:
                    parts.append((shapes, link_matrix(models.client, u, -1)[None], np.array([u])))
            self._static = scene.commit([scene.build(parts)])  # its BVH is built here, once per static layout
            self._static_key = models.static_version
        return self._static

    def _template(self, uid: int, label: str) -> list[Shape]:
        """Shapes of an upright body moved by this sim (kinematic robots), relative to its base, whose pose is
        the robot table's (x, y, 0, yaw): the base is teleported there every step."""
        key = (uid, label)
        if key not in self._templates:
            shapes = [Shape(-1, s.link, s.kind, s.radius, s.half_length, s.local, s.verts, s.faces)
                      for s in body_shapes(self.world.client, uid, self._mesh_table())]
            self._templates[key] = self._shared(shapes)
        return self._templates[key]

    def _shared(self, shapes: list[Shape]) -> list[Shape]:
        """Bodies (or links) with the same shapes, e.g. robots of one model, share one list, so they are cast
        (or built) as one group."""
        sig = b"".join(np.round(np.concatenate([s.local.ravel(), s.verts.ravel(), s.faces.ravel(),
                                                [s.kind, s.radius, s.half_length]]), 6).tobytes() for s in shapes)
        return self._groups.setdefault(sig, shapes)

    def _links(self, uid: int, label: str) -> dict[int, list[Shape]]:
        """Shapes of a body moved by physics, grouped by link, each framed relative to its link."""
        key = (uid, "links:" + label)
        if key not in self._link_templates:
            by_link: dict[int, list[Shape]] = {}
            for s in body_shapes(self.world.client, uid, self._mesh_table(), per_link=True):
                by_link.setdefault(s.link, []).append(Shape(-1, s.link, s.kind, s.radius, s.half_length, s.local,
                                                            s.verts, s.faces))
            self._link_templates[key] = {link: self._shared(shapes) for link, shapes in by_link.items()}
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

    def _physics(self) -> bool:
        """When the engine steps (a dynamic robot or model exists), gravity also acts on kinematic robots
        between teleports, so their bodies are read from PyBullet like the rest; otherwise the table is the pose."""
        return bool((~self.world.table.b["kinematic"]).any()) or self.world.models.has_dynamic_models()

    def _moving(self) -> list[Moving]:
        """Bodies moved by physics (dynamic robots, movable models, and every robot while the engine steps),
        each link at its pose now (joints move links relative to the base), grouped by shared link shapes.
        Which links and groups is cached while the robots and models stay the same; poses are read every cast."""
        w = self.world
        t = w.table
        physics = self._physics()
        key = (tuple(t.names), t.body.tobytes(), t.b["kinematic"].tobytes(), physics, w.models.version)
        if key != self._moving_key:
            bodies = [(int(t.body[i]), f"robot:{t.names[i]}:{id(w.specs[t.names[i]])}")
                      for i in (range(len(t)) if physics else np.flatnonzero(~t.b["kinematic"]))]
            bodies += [(u, f"model:{rec.name}:{id(rec)}") for rec in w.models.records.values()
                       if not rec.static for u in rec.uids]
            groups: dict[int, tuple[list[Shape], list[int], list[int]]] = {}
            links: list[tuple[int, int]] = []
            for uid, label in bodies:
                for link, shapes in self._links(uid, label).items():
                    entry = groups.setdefault(id(shapes), (shapes, [], []))
                    entry[1].append(len(links))
                    entry[2].append(uid)
                    links.append((uid, link))
            self._moving_links = links
            self._moving_groups = [(shapes, np.asarray(at, np.int64), np.asarray(us, np.int64))
                                   for shapes, at, us in groups.values() if shapes]
            self._moving_key = key
        if not self._moving_links:
            return []
        client = w.client
        poses = [link_pose(client, uid, link) for uid, link in self._moving_links]
        mats = pose_matrices(np.asarray([q[0] for q in poses]), np.asarray([q[1] for q in poses]))
        return [(shapes, mats[at], us) for shapes, at, us in self._moving_groups]

    def _form(self, shapes: list[Shape]) -> list[robots.ShapeForm]:
        if id(shapes) not in self._forms:
            self._forms[id(shapes)] = [robots.shape_form(s) for s in shapes]
        return self._forms[id(shapes)]

    def _dynamic_scene(self, z_band: tuple[float, float], rays: tuple[np.ndarray, np.ndarray] | None = None,
                       moving: list[Moving] | None = None) -> list[Geometry]:
        """The moving bodies cast as triangles (shapes the closed form does not cover, or all of them with
        `closed_form` off). With `rays` (origins, directions), kinematic robots built as triangles that no ray
        can reach are left out (see _reach). `moving`: this cast's _moving(), if already read."""
        w = self.world
        t, f = w.table, w.table.f
        upright: list[Part] = []
        reach: tuple[np.ndarray, float] | None = None
        computed = False
        if len(t) and not self._physics():
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
        moved = [g for g in (self._moving() if moving is None else moving)
                 if not (self.closed_form and robots.supported(g[0]))]
        return [g for g in (scene.build(upright, z_band), scene.build(moved)) if g is not None]

    def _scenes(self, z_band: tuple[float, float], rays: tuple[np.ndarray, np.ndarray] | None = None,
                moving: list[Moving] | None = None) -> list[Geometry]:
        """The Embree scenes to cast against: the static one (its BVH from load) and, when a moving shape is
        not covered by the closed form, a small one of those, built now."""
        static = self._static_scene()
        built = scene.commit(self._dynamic_scene(z_band, rays, moving))
        return [g for g in (static, built) if g is not None]

    def _closed_form_groups(self) -> list[tuple[list[robots.ShapeForm], np.ndarray]]:
        """(closed-form shapes, table rows) of the upright robots cast without a BVH; none under physics."""
        w = self.world
        t = w.table
        if not self.closed_form or not len(t) or self._physics():
            return []
        return [(self._form(shapes), rows) for shapes, rows, _ in self._upright_groups()
                if shapes and robots.supported(shapes)]

    def forget(self) -> None:
        """Drop every cached shape (bodies were removed or re-created, e.g. after a snapshot restore)."""
        self._templates.clear()
        self._groups.clear()
        self._link_templates.clear()
        self._forms.clear()
        self._static_key = self._upright_key = self._moving_key = None
        if self.fans is not None:
            self.fans = FanCache()

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

    def cast(self, origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
        with self._lock:  # one cast at a time: the work arrays are shared
            return self._cast(origins, ends, layout)

    def _cast(self, origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None
              ) -> tuple[np.ndarray, np.ndarray]:
        o = np.asarray(origins, np.float64).reshape(-1, 3)
        n = len(o)
        if n == 0:
            return np.ones(0), np.full(0, -1, np.int64)
        s = self._scratch
        d = np.subtract(np.asarray(ends, np.float64).reshape(-1, 3), o, out=s.get("d", n, np.float64, 3))
        best, uids = s.get("best", n, np.float64), s.get("uids", n, np.int64)
        best.fill(np.inf)
        uids.fill(-1)
        rg = layout_groups(layout, o, d) if layout is not None else None  # checks the layout describes the rays
        if layout is not None:  # a lidar's fans: horizontal rays at the fans' heights
            z_band = (float(layout.z.min()), float(layout.z.max()))
        else:
            z = np.concatenate([o[:, 2], o[:, 2] + d[:, 2]])
            z_band = (float(z.min()), float(z.max()))
        upright = self._closed_form_groups()
        moving = self._moving() if self._physics() else []  # read once: the closed form and the scene share it
        posed = [(self._form(shapes), mats, us) for shapes, mats, us in moving
                 if self.closed_form and robots.supported(shapes)]
        if upright or posed:  # moving bodies first: their hits shorten the rays the BVH traverses
            rg = robots.group_rays(o, d) if rg is None else rg
            t = self.world.table
            pose = np.column_stack([t.f["x"], t.f["y"], t.f["yaw"]])
            for forms, rows in upright:
                robots.cast_upright(rg, o, d, forms, pose[rows], t.body[rows], z_band, best, uids)
            for forms, mats, us in posed:
                robots.cast_posed(rg, o, d, forms, mats, us, z_band, best, uids)
        for g in self._scenes(z_band, (o, d), moving):
            if g is self._static and layout is not None and self.fans is not None:
                # full length: the same nearer hits as a limit of best
                t_g, u = self.fans.cast(g, layout, o, d, s)
            else:  # a later scene only looks closer than the hits so far
                t_g, u = scene.cast(g, o, d, np.minimum(best, 1.0, out=s.get("limit", n, np.float64)), s)
            nearer = np.less(t_g, best, out=s.get("nearer", n, np.bool_))
            np.copyto(best, t_g, where=nearer)
            np.copyto(uids, u, where=nearer)
        hit = np.isfinite(best, out=s.get("nearer", n, np.bool_))
        hit &= np.less_equal(best, 1.0, out=s.get("in_reach", n, np.bool_))
        return np.where(hit, best, 1.0), np.where(hit, uids, -1)  # new arrays: the caller keeps them


__all__ = ["EmbreeCaster"]
