"""PyBullet bodies for world models (ModelDescription → bodies), one body per link.

A link's collisions become one (compound) collision shape and its visuals one (compound) visual shape, so a
shelf of seven boards is one body, not seven. Plane geometry becomes a GEOM_PLANE body whose visual is a
tiled quad (UVs repeat every metre) so the ground texture shows in camera images. `build_models` creates
each distinct shape once and builds identical static links (e.g. rows of included shelves) with one
`createMultiBody(batchPositions=...)` call.
"""

from __future__ import annotations

from dataclasses import dataclass

import pybullet as p

from sim.errors import ErrorCode, FleetError
from sim.sdf_context import compose
from sim.sdf_shapes import ShapeCache, ground_body, ground_texture_file
from sim.types import Collision, Link, ModelDescription, Pose3D, Visual


@dataclass(frozen=True)
class BuiltModel:
    name: str
    body_uids: tuple[int, ...]  # in link order (a link with plane geometry adds its ground body after it)
    link_names: dict[int, dict[int, str]]  # body uid → PyBullet link index (-1: base) → SDF link name


@dataclass
class _Job:
    """One body to create: a (non-plane) link of a model at its world pose."""

    model: int
    link: Link
    pose: Pose3D
    static: bool
    uid: int = -1


def build_model(client: int, model: ModelDescription, *, ground_texture: str | None = None) -> BuiltModel:
    """Create the bodies of one model; `ground_texture` is the world's ground material (a texture file or a
    material name, see sim.sdf_shapes.ground_texture_file)."""
    return build_models(client, [model], ground_texture=ground_texture)[0]


def build_models(client: int, models: list[ModelDescription] | tuple[ModelDescription, ...], *,
                 ground_texture: str | None = None) -> list[BuiltModel]:
    """Create the bodies of many models, sharing shapes and batching identical static links.
    All or nothing: if any body cannot be made, the bodies made so far are removed again."""
    for m in models:
        if not m.static and any(lk.mass <= 0 for lk in m.links):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"model '{m.name}' is not static but a link has mass ≤ 0",
                             "give every link of a dynamic model a positive mass")
    jobs = [_Job(mi, link, compose(m.pose, link.pose), m.static) for mi, m in enumerate(models) for link in m.links]
    grounds: dict[tuple[int, str], int] = {}  # (model index, link name) → ground body uid
    try:
        for job in jobs:
            if _has_plane(job.link):
                texture = ground_texture_file(ground_texture, job.link)
                grounds[(job.model, job.link.name)] = ground_body(client, job.link, job.pose, texture)
        _create(client, jobs, ShapeCache(client))
    except (FleetError, p.error):
        for uid in [*grounds.values(), *(j.uid for j in jobs if j.uid >= 0)]:
            p.removeBody(uid, physicsClientId=client)
        raise
    per_model: list[list[_Job]] = [[] for _ in models]
    for job in jobs:
        per_model[job.model].append(job)
    out: list[BuiltModel] = []
    for mi, m in enumerate(models):
        uids: list[int] = []
        names: dict[int, dict[int, str]] = {}
        for job in per_model[mi]:
            for uid in (job.uid, grounds.get((mi, job.link.name), -1)):
                if uid >= 0:
                    uids.append(uid)
                    names[uid] = {-1: job.link.name}
        out.append(BuiltModel(m.name, tuple(uids), names))
    return out


def _has_plane(link: Link) -> bool:
    return any(c.geometry.kind == "plane" for c in link.collisions) or any(
        v.geometry.kind == "plane" for v in link.visuals)


def _create(client: int, jobs: list[_Job], shapes: ShapeCache) -> None:
    """Create every job's body: batched where static links share shapes and orientation."""
    groups: dict[tuple[object, ...], list[_Job]] = {}
    for job in jobs:
        solid = [c for c in job.link.collisions if c.geometry.kind != "plane"]
        shown = [v for v in job.link.visuals if v.geometry.kind != "plane"]
        if not solid and not shown and _has_plane(job.link):
            continue  # a pure ground link: its ground body is all there is
        if job.static:
            key = (shapes.key(solid, shown), job.pose.quaternion)
            groups.setdefault(key, []).append(job)
        else:
            _single(client, job, shapes, solid, shown)
    batched = False
    for group in groups.values():
        first = group[0]
        solid = [c for c in first.link.collisions if c.geometry.kind != "plane"]
        shown = [v for v in first.link.visuals if v.geometry.kind != "plane"]
        if len(group) == 1:
            _single(client, first, shapes, solid, shown)
            continue
        col, vis = shapes.collision(solid, static=True), shapes.visual(shown)
        uids = p.createMultiBody(0, col, vis, baseOrientation=first.pose.quaternion,
                                 batchPositions=[j.pose.position for j in group], physicsClientId=client)
        batched = True
        for job, uid in zip(group, uids, strict=True):
            job.uid = uid
            _finish(client, job, shown, shapes)
    if batched:  # batch creation leaves the client's body cache stale (getNumBodies, getBodyInfo)
        p.syncBodyInfo(physicsClientId=client)


def _single(client: int, job: _Job, shapes: ShapeCache, solid: list[Collision], shown: list[Visual]) -> None:
    col, vis = shapes.collision(solid, static=job.static), shapes.visual(shown)
    mass = 0.0 if job.static or (col < 0) else job.link.mass
    job.uid = p.createMultiBody(mass, col, vis, basePosition=job.pose.position,
                                baseOrientation=job.pose.quaternion, physicsClientId=client)
    _finish(client, job, shown, shapes)


def _finish(client: int, job: _Job, shown: list[Visual], shapes: ShapeCache) -> None:
    """Per-body properties: per-shape colours of compound visuals, friction, inertia."""
    shapes.colour(job.uid, shown)
    friction = next((c.friction for c in job.link.collisions if c.friction is not None), None)
    if friction is not None:
        p.changeDynamics(job.uid, -1, lateralFriction=friction, physicsClientId=client)
    ixx, _, _, iyy, _, izz = job.link.inertia
    if not job.static and min(ixx, iyy, izz) > 0:
        p.changeDynamics(job.uid, -1, localInertiaDiagonal=[ixx, iyy, izz], physicsClientId=client)


def remove_model(client: int, built: BuiltModel) -> None:
    for uid in built.body_uids:
        p.removeBody(uid, physicsClientId=client)
