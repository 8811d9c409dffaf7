"""The world's non-robot models: built from SDF descriptions or URDF files, queried and edited at run time."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

from sim.errors import ErrorCode, FleetError, unknown_name
from sim.robot_body import GROUND_GROUP
from sim.transforms import quat_to_rpy
from sim.types import Collision, Link, ModelDescription, Plane, Pose3D, Visual, WorldDescription
from sim.world_types import ModelState

if TYPE_CHECKING:
    from sim.bodies import BuiltModel

MAX_SPEED = 50.0


@dataclass
class ModelRecord:
    name: str
    uids: list[int]
    link_names: dict[int, dict[int, str]]  # uid → link index → name
    description: ModelDescription | None  # None for URDF models
    kind: str  # sdf | urdf | ground
    static: bool
    urdf_path: str | None = None
    body0_init: np.ndarray | None = None  # first body's world matrix when built (to recover the model frame)


class ModelRegistry:
    """Owns the PyBullet bodies of every non-robot model, by name."""

    def __init__(self, client: int) -> None:
        self.client = client
        self.records: dict[str, ModelRecord] = {}
        self.world_meta: WorldDescription = WorldDescription(name="world")
        self.version = 0  # bumped whenever bodies are added, removed or moved
        # bumped only when static bodies are (or a snapshot restore may have moved them): what caches of the
        # static scene (obstacle boxes, the ray caster's BVH) key on, so moving a movable model keeps them
        self.static_version = 0
        self._aabb_cache: tuple[int, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._dynamic_cache: tuple[tuple[int, int], bool] | None = None

    # ---- building ----------------------------------------------------------------------------------

    def add_ground_plane(self) -> None:
        """An infinite ground plane (the default world's floor)."""
        plane = Plane()
        link = Link("link", collisions=(Collision("collision", plane),), visuals=(Visual("visual", plane),))
        desc = ModelDescription("ground_plane", Pose3D(), True, (link,))
        col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[50, 50, 0.0005], visualFramePosition=[0, 0, -0.0005],
                                  rgbaColor=[0.8, 0.8, 0.8, 1], physicsClientId=self.client)
        uid = p.createMultiBody(0, col, vis, physicsClientId=self.client)
        p.setCollisionFilterGroupMask(uid, -1, GROUND_GROUP, 0xFFFF, physicsClientId=self.client)
        self.records[desc.name] = ModelRecord(desc.name, [uid], {uid: {-1: "link"}}, desc, "ground", True,
                                              body0_init=self._body_matrix(uid))

    def load_description(self, desc: WorldDescription) -> None:
        """Build every model of a world file at once (identical static shapes are batched)."""
        from sim.bodies import build_models

        for m in desc.models:
            self._check_new(m.name)
        for model, built in zip(desc.models, build_models(self.client, desc.models,
                                                           ground_texture=desc.ground_material), strict=True):
            self._register(model, built)
        self.world_meta = replace(desc, models=())
        g = desc.physics.gravity
        p.setGravity(g[0], g[1], g[2], physicsClientId=self.client)

    def add_model(self, model: ModelDescription) -> None:
        from sim.bodies import build_model

        self._check_new(model.name)
        self._register(model, build_model(self.client, model, ground_texture=self.world_meta.ground_material))

    def _check_new(self, name: str) -> None:
        if name in self.records:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a model named '{name}' already exists",
                             "pick another name")

    def _register(self, model: ModelDescription, built: BuiltModel) -> None:
        is_ground = all(c.geometry.kind == "plane" for lk in model.links for c in lk.collisions) and any(
            lk.collisions for lk in model.links)
        if is_ground:
            for uid in built.body_uids:
                p.setCollisionFilterGroupMask(uid, -1, GROUND_GROUP, 0xFFFF, physicsClientId=self.client)
        self.records[model.name] = ModelRecord(model.name, list(built.body_uids), built.link_names, model,
                                               "ground" if is_ground else "sdf", model.static,
                                               body0_init=self._body_matrix(built.body_uids[0]))
        self._changed(model.static)

    def add_urdf(self, name: str, path: str, pose: Pose3D, static: bool) -> None:
        self._check_new(name)
        try:
            uid = p.loadURDF(path, pose.position, pose.quaternion, useFixedBase=static,
                             physicsClientId=self.client)
        except p.error as exc:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{path}: PyBullet cannot load this URDF: {exc}",
                             "validate it with `fleetnav check robot`") from exc
        links = {-1: p.getBodyInfo(uid, physicsClientId=self.client)[0].decode()}
        for j in range(p.getNumJoints(uid, physicsClientId=self.client)):
            links[j] = p.getJointInfo(uid, j, physicsClientId=self.client)[12].decode()
        self.records[name] = ModelRecord(name, [uid], {uid: links}, None, "urdf", static, path)
        self._changed(static)

    def remove(self, name: str) -> None:
        rec = self._get(name)
        if rec.kind == "ground":
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{name}' is the ground plane", "it cannot be deleted")
        for uid in rec.uids:
            p.removeBody(uid, physicsClientId=self.client)
        del self.records[name]
        self._changed(rec.static)

    def _changed(self, static: bool) -> None:
        self.version += 1
        self.static_version += static

    def invalidate(self) -> None:
        """Bodies may have moved behind the registry's back (a snapshot restore): drop every cache."""
        self._changed(True)

    # ---- queries -------------------------------------------------------------------------------------

    def names(self) -> list[str]:
        return list(self.records)

    def _get(self, name: str) -> ModelRecord:
        if name not in self.records:
            raise unknown_name("model", name, list(self.records), ErrorCode.UNKNOWN_MODEL)
        return self.records[name]

    def labels(self) -> dict[int, tuple[str, dict[int, str]]]:
        """body uid → (model name, link index → link name)."""
        return {uid: (rec.name, rec.link_names.get(uid, {-1: "link"}))
                for rec in self.records.values() for uid in rec.uids}

    def name_of(self, uid: int) -> str | None:
        return next((r.name for r in self.records.values() if uid in r.uids), None)

    def ground_uids(self) -> set[int]:
        return {uid for r in self.records.values() if r.kind == "ground" for uid in r.uids}

    def obstacle_aabbs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(uids, mins (n, 3), maxs (n, 3)) of every non-ground body: the static ones, then the moving ones."""
        uids_s, lo_s, hi_s = self.static_obstacle_aabbs()
        uids_m, lo_m, hi_m = self.moving_obstacle_aabbs()
        if not uids_m.size:
            return uids_s, lo_s, hi_s
        return np.concatenate([uids_s, uids_m]), np.vstack([lo_s, lo_m]), np.vstack([hi_s, hi_m])

    def static_obstacle_aabbs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """obstacle_aabbs of the static bodies: the same arrays until a body is added, removed or moved."""
        if self._aabb_cache is None or self._aabb_cache[0] != self.static_version:
            uids = [u for r in self.records.values() if r.kind != "ground" and r.static for u in r.uids]
            boxes = [self._body_aabb(u) for u in uids]
            self._aabb_cache = (self.static_version, np.array(uids, dtype=np.int64),
                                np.array([b[0] for b in boxes]).reshape(-1, 3),
                                np.array([b[1] for b in boxes]).reshape(-1, 3))
        return self._aabb_cache[1:]

    def moving_obstacle_aabbs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """obstacle_aabbs of the non-static bodies, measured now."""
        moving = [u for r in self.records.values() if r.kind != "ground" and not r.static for u in r.uids]
        boxes = [self._body_aabb(u) for u in moving]
        return (np.array(moving, dtype=np.int64), np.array([b[0] for b in boxes]).reshape(-1, 3),
                np.array([b[1] for b in boxes]).reshape(-1, 3))

    def _body_aabb(self, uid: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """AABB of a body including all its links (URDF models have several)."""
        n = p.getNumJoints(uid, physicsClientId=self.client)
        boxes = [p.getAABB(uid, k, physicsClientId=self.client) for k in range(-1, n)]
        lo = tuple(min(b[0][i] for b in boxes) for i in range(3))
        hi = tuple(max(b[1][i] for b in boxes) for i in range(3))
        return lo, hi

    def has_dynamic_models(self) -> bool:
        # Asked several times per physics step (every lidar cast): the answer is kept per registry version
        # (records are only added or removed with a version bump; the ground plane, added without one, is static).
        key = (self.version, len(self.records))
        if self._dynamic_cache is None or self._dynamic_cache[0] != key:
            self._dynamic_cache = (key, any(not r.static for r in self.records.values()))
        return self._dynamic_cache[1]

    def unstable_model(self) -> str | None:
        for r in self.records.values():
            if r.static:
                continue
            for uid in r.uids:
                lin, ang = p.getBaseVelocity(uid, physicsClientId=self.client)
                pos, _ = p.getBasePositionAndOrientation(uid, physicsClientId=self.client)
                vals = (*lin, *ang, *pos)
                if not all(math.isfinite(v) for v in vals) or math.hypot(*lin) > MAX_SPEED:
                    return r.name
        return None

    def state(self, name: str) -> ModelState:
        rec = self._get(name)
        uid = rec.uids[0]
        pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=self.client)
        lin, ang = p.getBaseVelocity(uid, physicsClientId=self.client)
        r, pi, y = quat_to_rpy(orn)
        if rec.description is not None and rec.description.links:
            # SDF models are built one body per link: report the model frame, not the first link's.
            base = self.model_pose(rec)
            return ModelState(name, base, _v3(lin), _v3(ang), rec.static, rec.kind)
        return ModelState(name, Pose3D(pos[0], pos[1], pos[2], r, pi, y), _v3(lin), _v3(ang), rec.static, rec.kind)

    def _body_matrix(self, uid: int) -> np.ndarray:
        pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=self.client)
        return Pose3D(pos[0], pos[1], pos[2], *quat_to_rpy(orn)).matrix()

    def model_pose(self, rec: ModelRecord) -> Pose3D:
        """The model frame now: how its first body moved since it was built, applied to the built pose."""
        assert rec.description is not None and rec.body0_init is not None
        if rec.static:
            return rec.description.pose
        moved = self._body_matrix(rec.uids[0]) @ np.linalg.inv(rec.body0_init)
        return Pose3D.from_matrix(moved @ rec.description.pose.matrix())

    def set_state(self, name: str, pose: Pose3D | None, linear: tuple[float, float, float] | None,
                  angular: tuple[float, float, float] | None) -> None:
        rec = self._get(name)
        self._changed(rec.static and pose is not None)
        if pose is not None:
            if rec.description is not None:
                delta = pose.matrix() @ np.linalg.inv(self.model_pose(rec).matrix())
                for uid in rec.uids:
                    new = Pose3D.from_matrix(delta @ self._body_matrix(uid))
                    p.resetBasePositionAndOrientation(uid, new.position, new.quaternion, physicsClientId=self.client)
                if rec.static:  # a static model's frame is its description; a moving one's is its body
                    rec.description = replace(rec.description, pose=pose)
            else:
                p.resetBasePositionAndOrientation(rec.uids[0], pose.position, pose.quaternion,
                                                  physicsClientId=self.client)
        if linear is not None or angular is not None:
            if rec.static:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"model '{name}' is static and cannot move",
                                 "spawn it with static=false")
            for uid in rec.uids:
                p.resetBaseVelocity(uid, linear or (0, 0, 0), angular or (0, 0, 0), physicsClientId=self.client)

    def apply_force(self, name: str, force: tuple[float, float, float], torque: tuple[float, float, float],
                    link: int = -1) -> None:
        rec = self._get(name)
        if rec.static:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"model '{name}' is static: forces do not move it",
                             "apply forces to non-static models")
        uid = rec.uids[0]
        pos, _ = p.getBasePositionAndOrientation(uid, physicsClientId=self.client)
        p.applyExternalForce(uid, link, force, pos, p.WORLD_FRAME, physicsClientId=self.client)
        p.applyExternalTorque(uid, link, torque, p.WORLD_FRAME, physicsClientId=self.client)

    def description(self) -> WorldDescription:
        """The current static world as a description (SDF models at their current poses)."""
        models = []
        for rec in self.records.values():
            if rec.description is None:
                continue
            d = rec.description
            models.append(replace(d, pose=self.model_pose(rec)) if not d.static else d)
        return replace(self.world_meta, models=tuple(models))

    def urdf_models(self) -> list[tuple[str, str]]:
        return [(r.name, r.urdf_path or "") for r in self.records.values() if r.kind == "urdf"]


def _v3(v: tuple[float, ...] | list[float]) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def check_path(path: str) -> str:
    if not Path(path).is_file():
        raise FleetError(ErrorCode.NOT_FOUND, f"no such file: {path}")
    return path
