"""Collision geometry for ray casting outside PyBullet: each body's shapes read back from the engine, as
triangles (boxes, meshes, planes: exact) or as convex proxies that enclose a curved shape (cylinders, spheres,
capsules) and are refined analytically after the hit (sim/raycast_exact.py).

Shapes come from `getCollisionShapeData` (what Bullet really collides with), convex meshes from
`getMeshData` (the hull points, already scaled), and concave static meshes, which Bullet does not hand back,
from the model description's mesh file (.obj or .stl, the formats sim.sdf_geometry accepts).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as p
from scipy.spatial import ConvexHull

from sim.errors import ErrorCode, FleetError
from sim.types import Mesh

# Shape kinds. Triangles of BOX/MESH/PLANE are the shape itself; the others are refined analytically.
BOX, SPHERE, CYLINDER, CAPSULE, MESH, CONCAVE, PLANE = range(7)
CURVED = (SPHERE, CYLINDER, CAPSULE)
PROXY_SEGMENTS = 8  # sides of the prism / sphere proxy: a few % larger than the shape, refined after the hit
PLANE_HALF = 2000.0  # m: half side of the finite quad standing in for an infinite plane


@dataclass(frozen=True)
class Shape:
    """One collision shape: kind, size, its frame relative to the body pose it was captured at, and, for
    triangle kinds, its triangles in that frame."""

    uid: int
    link: int  # PyBullet link index (-1: base)
    kind: int
    radius: float
    half_length: float  # cylinder / capsule: half the axis length (z of the shape frame)
    local: np.ndarray  # 4×4: shape frame in the body frame
    verts: np.ndarray  # (V, 3) in the shape frame (a proxy's for curved kinds)
    faces: np.ndarray  # (T, 3) vertex indices, wound outward

    @property
    def z_range(self) -> tuple[float, float]:
        """z extent in the body frame (for bodies that only turn about z: culling by ray heights)."""
        z = self.verts @ self.local[2, :3] + self.local[2, 3]
        return float(z.min()), float(z.max())


def pose_matrix(pos: tuple[float, ...] | np.ndarray, orn: tuple[float, ...] | np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = np.reshape(p.getMatrixFromQuaternion(list(orn)), (3, 3))
    m[:3, 3] = pos
    return m


def pose_matrices(pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """(N, 4, 4) poses from positions (N, 3) and unit quaternions (N, 4, x y z w as PyBullet gives them), in
    one pass (pose_matrix per body costs ~15 µs of Python)."""
    x, y, z, w = np.asarray(quat, np.float64).T
    m = np.zeros((len(x), 4, 4))
    m[:, 0, 0], m[:, 0, 1], m[:, 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    m[:, 1, 0], m[:, 1, 1], m[:, 1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    m[:, 2, 0], m[:, 2, 1], m[:, 2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    m[:, :3, 3] = pos
    m[:, 3, 3] = 1.0
    return m


def link_pose(client: int, uid: int, link: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """World position and quaternion of a link's inertial frame."""
    if link < 0:
        return p.getBasePositionAndOrientation(uid, physicsClientId=client)
    st = p.getLinkState(uid, link, computeForwardKinematics=1, physicsClientId=client)
    return st[0], st[1]


def link_matrix(client: int, uid: int, link: int) -> np.ndarray:
    """World pose of a link's inertial frame (the frame collision shapes are given in)."""
    if link < 0:
        pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    else:
        st = p.getLinkState(uid, link, computeForwardKinematics=1, physicsClientId=client)
        pos, orn = st[0], st[1]
    return pose_matrix(pos, orn)


def body_shapes(client: int, uid: int, meshes: dict[tuple[int, int], list[Mesh | None]], *,
                per_link: bool = False) -> list[Shape]:
    """Every collision shape of body `uid`, framed relative to its base pose now (or, with `per_link`, to
    its own link's inertial frame). `meshes` maps (uid, link) → the description's collision geometries in
    order (Mesh, or None for other kinds)."""
    base_inv = np.linalg.inv(link_matrix(client, uid, -1))
    out: list[Shape] = []
    for link in range(-1, p.getNumJoints(uid, physicsClientId=client)):
        data = p.getCollisionShapeData(uid, link, physicsClientId=client)
        if not data:
            continue
        # The base's own shapes are framed exactly (no pose round trip), so captures do not depend on the pose.
        in_base = np.eye(4) if per_link or link < 0 else base_inv @ link_matrix(client, uid, link)
        for k, d in enumerate(data):
            geom, dims, lpos, lorn = int(d[2]), d[3], d[5], d[6]
            frame = in_base @ pose_matrix(lpos, lorn)
            if geom == p.GEOM_BOX:
                out.append(Shape(uid, link, BOX, 0.0, 0.0, frame, *box_mesh(np.asarray(dims) / 2)))
            elif geom == p.GEOM_SPHERE:
                out.append(Shape(uid, link, SPHERE, dims[0], 0.0, frame, *sphere_proxy(dims[0])))
            elif geom in (p.GEOM_CYLINDER, p.GEOM_CAPSULE):
                r, h = float(dims[1]), float(dims[0]) / 2
                kind = CYLINDER if geom == p.GEOM_CYLINDER else CAPSULE
                out.append(Shape(uid, link, kind, r, h, frame, *prism_proxy(r, h + (r if kind == CAPSULE else 0.0))))
            elif geom == p.GEOM_PLANE:
                out.append(Shape(uid, link, PLANE, 0.0, 0.0, frame @ plane_frame(np.asarray(dims)), *plane_mesh()))
            elif geom == p.GEOM_MESH:
                out.append(_mesh_shape(client, uid, link, k, in_base, frame, meshes))
    return out


def _mesh_shape(client: int, uid: int, link: int, k: int, in_base: np.ndarray, frame: np.ndarray,
                meshes: dict[tuple[int, int], list[Mesh | None]]) -> Shape:
    _, verts = p.getMeshData(uid, link, collisionShapeIndex=k, physicsClientId=client)
    if len(verts) >= 4:  # a convex hull: Bullet gives its points in the link frame, scaled
        pts = np.asarray(verts, dtype=np.float64)
        return Shape(uid, link, MESH, 0.0, 0.0, in_base, *_hull(pts))
    geoms = meshes.get((uid, link), [])
    mesh = geoms[k] if k < len(geoms) else None
    if mesh is None:
        raise FleetError(ErrorCode.UNSUPPORTED, f"body {uid} link {link}: a concave mesh the ray caster cannot "
                         "read back (no mesh file in the model description)",
                         "use the 'pybullet' ray caster for this world")
    tris = load_mesh_triangles(mesh.path) * np.asarray(mesh.scale)
    return Shape(uid, link, CONCAVE, 0.0, 0.0, frame, tris.reshape(-1, 3), np.arange(tris.shape[0] * 3).reshape(-1, 3))


def _hull(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Convex hull as (vertices, faces) with faces wound so their normals point outward."""
    hull = ConvexHull(pts)
    used = np.unique(hull.simplices)
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(used.size)
    verts, faces = pts[used], remap[hull.simplices]
    tris = verts[faces]
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    flip = np.einsum("ij,ij->i", n, tris[:, 0] - verts.mean(axis=0)) < 0
    faces[flip] = faces[flip][:, ::-1]
    return verts, faces


def box_mesh(half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return _hull(np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * half)


def prism_proxy(r: float, half: float, n: int = PROXY_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """A closed n-gon prism around the z axis whose sides touch a circle of radius r (so it encloses it)."""
    rc = r / math.cos(math.pi / n)
    a = 2 * math.pi * np.arange(n) / n
    ring = np.column_stack([rc * np.cos(a), rc * np.sin(a)])
    return _hull(np.vstack([np.column_stack([ring, np.full(n, -half)]), np.column_stack([ring, np.full(n, half)])]))


def sphere_proxy(r: float, n: int = PROXY_SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """A convex polyhedron enclosing a sphere: a UV sphere scaled until every face clears the radius."""
    lat = np.linspace(-math.pi / 2, math.pi / 2, n // 2 + 1)
    lon = 2 * math.pi * np.arange(n) / n
    pts = np.array([[math.cos(b) * math.cos(a), math.cos(b) * math.sin(a), math.sin(b)] for b in lat for a in lon])
    pts = np.unique(np.round(pts, 12), axis=0)
    hull = ConvexHull(pts)
    inner = float(np.min(-hull.equations[:, 3]))  # distance of the nearest face plane from the centre
    return _hull(pts * (r / inner) * (1 + 1e-9))


def plane_frame(normal: np.ndarray) -> np.ndarray:
    """A frame whose z axis is the plane normal."""
    z = normal / np.linalg.norm(normal)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[0]) > 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, np.cross(z, x), z
    return m


def plane_mesh() -> tuple[np.ndarray, np.ndarray]:
    h = PLANE_HALF
    return np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], float), np.array([[0, 1, 2], [0, 2, 3]])


def load_mesh_triangles(path: str) -> np.ndarray:
    """(T, 3, 3) triangles of an .obj (polygons fanned) or .stl (ASCII or binary) file."""
    suffix = Path(path).suffix.lower()
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{path}: cannot read mesh: {exc}") from exc
    if suffix == ".obj":
        verts: list[list[float]] = []
        tris: list[list[int]] = []
        for line in data.decode("utf-8", "replace").splitlines():
            parts = line.split()
            if parts and parts[0] == "v":
                verts.append([float(v) for v in parts[1:4]])
            elif parts and parts[0] == "f":
                idx = [int(t.split("/")[0]) for t in parts[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                tris += [[idx[0], idx[j], idx[j + 1]] for j in range(1, len(idx) - 1)]
        return np.asarray(verts, float)[np.asarray(tris, int)]
    if suffix == ".stl":
        if data[:5].lower() == b"solid" and b"facet" in data[:1000]:
            nums = [float(t) for line in data.decode("ascii", "replace").splitlines()
                    if (s := line.split()) and s[0] == "vertex" for t in s[1:4]]
            return np.asarray(nums, float).reshape(-1, 3, 3)
        (count,) = struct.unpack_from("<I", data, 80)
        rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                            count=count, offset=84)
        return rec["v"].astype(np.float64)
    raise FleetError(ErrorCode.INVALID_CONFIG, f"{path}: mesh format '{suffix}' is not supported",
                     "use .obj or .stl")
