"""Planar footprints of a world's collision geometry inside a height slab, plus mesh bounding boxes.

Shared by the rasteriser (cells) and the exact checker (fcl), so both see the same obstacles: every
non-plane collision whose vertical extent overlaps the slab. Upright boxes and cylinders give exact
rectangles and circles; tilted ones give the convex hull of their projection (conservative).
"""

from __future__ import annotations

import logging
import math
import struct
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.spatial import ConvexHull

from sim.types import Box, Collision, Cylinder, Mesh, Pose3D, Sphere, WorldDescription

log = logging.getLogger(__name__)

DEFAULT_SLAB: tuple[float, float] = (0.02, 1.0)  # robot height band, m: floor decals and overhangs excluded
_UPRIGHT = 1.0 - 1e-9
_N_ARC = 32  # vertices per circle when a tilted cylinder is projected


@dataclass(frozen=True, slots=True)
class Footprint:
    """A convex planar obstacle: a circle (centre, radius) or a CCW convex polygon (vertices)."""

    model: str
    collision: str
    kind: str  # "circle" | "polygon"
    centre: tuple[float, float]
    radius: float = 0.0
    vertices: np.ndarray | None = None  # (n, 2) CCW when kind == "polygon"


def world_footprints(description: WorldDescription,
                     slab: tuple[float, float] = DEFAULT_SLAB) -> list[Footprint]:
    """Footprints of every non-plane collision of `description` that reaches into `slab` (z, m)."""
    out: list[Footprint] = []
    for model in description.models:
        for _, col, wp in model.world_collisions():
            fp = collision_footprint(model.name, col, wp, slab)
            if fp is not None:
                out.append(fp)
    return out


def collision_footprint(model: str, col: Collision, wp: Pose3D, slab: tuple[float, float]) -> Footprint | None:
    g = col.geometry
    m = wp.matrix()
    rot, c = m[:3, :3], m[:3, 3]
    if isinstance(g, Sphere):
        lo, hi = c[2] - g.radius, c[2] + g.radius
        if hi <= slab[0] or lo >= slab[1]:
            return None
        d = 0.0 if slab[0] <= c[2] <= slab[1] else min(abs(c[2] - slab[0]), abs(c[2] - slab[1]))
        return Footprint(model, col.name, "circle", (c[0], c[1]), math.sqrt(max(g.radius**2 - d**2, 0.0)))
    if isinstance(g, Cylinder):
        axis = rot[:, 2]
        half_z = 0.5 * g.length * abs(axis[2]) + g.radius * math.sqrt(max(1.0 - axis[2] ** 2, 0.0))
        if c[2] + half_z <= slab[0] or c[2] - half_z >= slab[1]:
            return None
        if abs(axis[2]) >= _UPRIGHT:
            return Footprint(model, col.name, "circle", (c[0], c[1]), g.radius)
        # Circumscribed polygons of both end circles, so the hull contains the true projection.
        a = np.linspace(0, 2 * math.pi, _N_ARC, endpoint=False)
        r = g.radius / math.cos(math.pi / _N_ARC)
        ring = np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)])
        pts = np.vstack([ring + np.array([0.0, 0.0, s * g.length / 2]) for s in (-1, 1)]) @ rot.T + c
        return _hull_footprint(model, col.name, pts[:, :2])
    if isinstance(g, Box | Mesh):
        lo3, hi3 = local_box(g)
        corners = np.array([[x, y, z] for x in (lo3[0], hi3[0]) for y in (lo3[1], hi3[1])
                            for z in (lo3[2], hi3[2])]) @ rot.T + c
        if corners[:, 2].max() <= slab[0] or corners[:, 2].min() >= slab[1]:
            return None
        return _hull_footprint(model, col.name, corners[:, :2])
    return None  # planes are the floor


def _hull_footprint(model: str, name: str, pts: np.ndarray) -> Footprint:
    hull = ConvexHull(pts)
    verts = pts[hull.vertices]  # scipy returns 2D hull vertices counter-clockwise
    return Footprint(model, name, "polygon", (float(verts[:, 0].mean()), float(verts[:, 1].mean())),
                     vertices=verts)


def local_box(g: Box | Mesh) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(g, Box):
        half = 0.5 * np.asarray(g.size, dtype=float)
        return -half, half
    bb = mesh_bounds(g.path)
    scale = np.asarray(g.scale, dtype=float)
    if bb is None:
        log.warning("mesh %s unreadable: using a unit box scaled by %s as its footprint", g.uri, g.scale)
        return -0.5 * np.abs(scale), 0.5 * np.abs(scale)
    lo, hi = np.asarray(bb[0]) * scale, np.asarray(bb[1]) * scale
    return np.minimum(lo, hi), np.maximum(lo, hi)


@lru_cache(maxsize=256)
def mesh_bounds(path: str) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
    """Axis-aligned bounds (min, max) of a mesh file's vertices: OBJ, STL (ASCII/binary) or COLLADA.

    COLLADA node transforms are not applied (the raw vertex positions are used). None if unreadable.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError:
        return None
    suffix = p.suffix.lower()
    try:
        if suffix == ".obj":
            v = np.array([ln.split()[1:4] for ln in raw.decode("utf-8", "replace").splitlines()
                          if ln.startswith("v ")], dtype=float)
        elif suffix == ".stl":
            v = _stl_vertices(raw)
        elif suffix == ".dae":
            v = _dae_vertices(raw)
        else:
            return None
    except (ValueError, ET.ParseError, struct.error):
        return None
    if v.size == 0:
        return None
    lo, hi = v.min(axis=0), v.max(axis=0)
    return (float(lo[0]), float(lo[1]), float(lo[2])), (float(hi[0]), float(hi[1]), float(hi[2]))


def _stl_vertices(raw: bytes) -> np.ndarray:
    if len(raw) >= 84:
        (n,) = struct.unpack_from("<I", raw, 80)
        if len(raw) == 84 + 50 * n:  # binary: normal + 3 vertices (12 float32) + 2-byte attribute each
            rec = np.frombuffer(raw, dtype=np.uint8, offset=84).reshape(n, 50)[:, 12:48]
            return np.ascontiguousarray(rec).view("<f4").reshape(-1, 3).astype(float)
    text = raw.decode("utf-8", "replace")
    return np.array([ln.split()[1:4] for ln in text.splitlines() if ln.strip().startswith("vertex")],
                    dtype=float).reshape(-1, 3)


def _dae_vertices(raw: bytes) -> np.ndarray:
    root = ET.fromstring(raw)
    chunks = [np.array((el.text or "").split(), dtype=float) for el in root.iter()
              if el.tag.endswith("float_array") and "position" in (el.get("id") or "").lower()]
    return np.concatenate(chunks).reshape(-1, 3) if chunks else np.zeros((0, 3))
