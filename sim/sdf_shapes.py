"""PyBullet collision/visual shapes for SDF geometry, created once per distinct shape, and ground bodies.

PyBullet names differ from SDF: a collision cylinder takes `height`, a visual one `length`; compound
shapes take per-shape frames but no per-shape colour (set after creation with changeVisualShape).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

from sim.errors import ErrorCode, FleetError
from sim.read_policy import allowed
from sim.resources import shipped
from sim.types import Box, Collision, Cylinder, Geometry, Link, Mesh, Plane, Pose3D, Sphere, Visual

DEFAULT_TEXTURE = shipped("worlds", "textures", "floor_tiles.png")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tga", ".bmp")
TILE_M = 1.0  # the ground texture repeats every metre
WHITE = (1.0, 1.0, 1.0, 1.0)


def _geom(g: Geometry) -> dict[str, Any]:
    """Shape type and size arguments shared by the single and array PyBullet calls."""
    if isinstance(g, Box):
        return {"type": p.GEOM_BOX, "half": [s / 2 for s in g.size], "radius": 0.0, "length": 0.0}
    if isinstance(g, Cylinder):
        return {"type": p.GEOM_CYLINDER, "half": [0, 0, 0], "radius": g.radius, "length": g.length}
    if isinstance(g, Sphere):
        return {"type": p.GEOM_SPHERE, "half": [0, 0, 0], "radius": g.radius, "length": 0.0}
    if isinstance(g, Mesh):
        return {"type": p.GEOM_MESH, "half": [0, 0, 0], "radius": 0.0, "length": 0.0, "file": g.path,
                "scale": list(g.scale)}
    raise FleetError(ErrorCode.INTERNAL, f"no PyBullet shape for {g.kind} here")


class ShapeCache:
    """Shape ids of one build, keyed by geometry + frame (+ colour), so repeated models share shapes."""

    def __init__(self, client: int) -> None:
        self.client = client
        self._col: dict[tuple[object, ...], int] = {}
        self._vis: dict[tuple[object, ...], int] = {}

    @staticmethod
    def key(solid: list[Collision], shown: list[Visual]) -> tuple[object, ...]:
        return (tuple((c.geometry, c.pose) for c in solid), tuple((v.geometry, v.pose, v.rgba) for v in shown))

    def collision(self, solid: list[Collision], *, static: bool) -> int:
        if not solid:
            return -1
        k = (tuple((c.geometry, c.pose) for c in solid), static)
        if k not in self._col:
            # Static meshes collide as the exact triangle mesh; dynamic ones as their convex hull.
            flags = p.GEOM_FORCE_CONCAVE_TRIMESH if static else 0
            self._col[k] = self._call(solid, "collision", flags)
        return self._col[k]

    def visual(self, shown: list[Visual]) -> int:
        if not shown:
            return -1
        k = tuple((v.geometry, v.pose, v.rgba) for v in shown)
        if k not in self._vis:
            self._vis[k] = self._call(shown, "visual", 0)
        return self._vis[k]

    def colour(self, uid: int, shown: list[Visual]) -> None:
        """Per-shape colours of a compound visual (a single visual got its colour at creation)."""
        if len(shown) > 1:
            for i, v in enumerate(shown):
                if v.rgba != WHITE:
                    p.changeVisualShape(uid, -1, shapeIndex=i, rgbaColor=v.rgba, physicsClientId=self.client)

    def _call(self, parts: list[Collision] | list[Visual], kind: str, flags: int) -> int:
        gs = [_geom(x.geometry) for x in parts]
        pos = [list(x.pose.position) for x in parts]
        orn = [list(x.pose.quaternion) for x in parts]
        try:
            if len(parts) == 1:
                return self._single(gs[0], pos[0], orn[0], kind, flags, parts[0])
            common: dict[str, Any] = {
                "shapeTypes": [g["type"] for g in gs], "radii": [g["radius"] for g in gs],
                "halfExtents": [g["half"] for g in gs], "lengths": [g["length"] for g in gs],
                "fileNames": [g.get("file", "") for g in gs], "meshScales": [g.get("scale", [1, 1, 1]) for g in gs],
                "flags": [flags] * len(gs), "physicsClientId": self.client}
            if kind == "collision":
                return int(p.createCollisionShapeArray(collisionFramePositions=pos, collisionFrameOrientations=orn,
                                                       **common))
            return int(p.createVisualShapeArray(visualFramePositions=pos, visualFrameOrientations=orn, **common))
        except p.error as exc:
            files = sorted({g["file"] for g in gs if "file" in g})
            raise FleetError(ErrorCode.INVALID_CONFIG, f"PyBullet could not create a {kind} shape"
                             + (f" from {', '.join(files)}" if files else ""),
                             "check that the mesh file is a valid OBJ or STL") from exc

    def _single(self, g: dict[str, Any], pos: list[float], orn: list[float], kind: str, flags: int,
                part: Collision | Visual) -> int:
        args: dict[str, Any] = {"radius": g["radius"], "halfExtents": g["half"], "physicsClientId": self.client}
        if "file" in g:
            args.update(fileName=g["file"], meshScale=g["scale"])
        if kind == "collision":
            return int(p.createCollisionShape(g["type"], height=g["length"], collisionFramePosition=pos,
                                              collisionFrameOrientation=orn, flags=flags, **args))
        assert isinstance(part, Visual)
        return int(p.createVisualShape(g["type"], length=g["length"], visualFramePosition=pos,
                                       visualFrameOrientation=orn, rgbaColor=part.rgba, **args))


def ground_texture_file(world_material: str | None, link: Link) -> str | None:
    """The texture for a link's ground visual: the world's texture file if it is an image PyBullet can load,
    else the shipped tile texture when the ground names any material, else none (plain colour)."""
    planes = [v for v in link.visuals if v.geometry.kind == "plane"]
    if not planes:
        return None
    if world_material and Path(world_material).suffix.lower() in IMAGE_SUFFIXES and Path(world_material).is_file() \
            and allowed(Path(world_material).resolve()):
        return world_material
    if world_material or any(v.material for v in planes):
        return str(DEFAULT_TEXTURE)
    return None


def ground_body(client: int, link: Link, pose: Pose3D, texture: str | None) -> int:
    """A static body for a link's plane collision and visual (an infinite plane and a tiled quad)."""
    pc = next((c for c in link.collisions if isinstance(c.geometry, Plane)), None)
    pv = next((v for v in link.visuals if isinstance(v.geometry, Plane)), None)
    col = vis = -1
    if pc is not None:
        assert isinstance(pc.geometry, Plane)
        col = p.createCollisionShape(p.GEOM_PLANE, planeNormal=list(pc.geometry.normal),
                                     collisionFramePosition=pc.pose.position,
                                     collisionFrameOrientation=pc.pose.quaternion, physicsClientId=client)
    if pv is not None:
        assert isinstance(pv.geometry, Plane)
        verts, uvs, normal = _quad(pv.geometry)
        vis = p.createVisualShape(p.GEOM_MESH, vertices=verts, indices=[0, 1, 2, 0, 2, 3], uvs=uvs,
                                  normals=[normal] * 4, rgbaColor=pv.rgba, visualFramePosition=pv.pose.position,
                                  visualFrameOrientation=pv.pose.quaternion, physicsClientId=client)
    uid = int(p.createMultiBody(0, col, vis, basePosition=pose.position, baseOrientation=pose.quaternion,
                                physicsClientId=client))
    if texture is not None and vis >= 0:
        tex = p.loadTexture(texture, physicsClientId=client)
        p.changeVisualShape(uid, -1, textureUniqueId=tex, physicsClientId=client)
    return uid


def _quad(plane: Plane) -> tuple[list[list[float]], list[list[float]], list[float]]:
    """Corners of a size-x by size-y quad across the plane (CCW seen from the normal) and tiling UVs."""
    n = np.asarray(plane.normal, float)
    n /= np.linalg.norm(n)
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = a - a.dot(n) * n
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    hx, hy = plane.size[0] / 2, plane.size[1] / 2
    corners = [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
    verts = [list(map(float, cx * u + cy * v)) for cx, cy in corners]
    uvs = [[cx / TILE_M, cy / TILE_M] for cx, cy in corners]
    return verts, uvs, list(map(float, n))
