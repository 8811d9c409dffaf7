"""Hand-built WorldDescriptions for the planning tests (no SDF files needed)."""

from __future__ import annotations

from sim.types import Box, Collision, Cylinder, Link, ModelDescription, Pose3D, Sphere, WorldDescription


def box(name: str, x: float, y: float, sx: float, sy: float, yaw: float = 0.0, h: float = 1.0,
        z0: float = 0.0) -> ModelDescription:
    """A box of footprint sx × sy standing on z0, height h, rotated by yaw."""
    return ModelDescription(name, Pose3D(x, y, z0 + h / 2, 0, 0, yaw), True,
                            (Link("link", collisions=(Collision("c", Box((sx, sy, h))),)),))


def cylinder(name: str, x: float, y: float, r: float, h: float = 1.0, z0: float = 0.0) -> ModelDescription:
    return ModelDescription(name, Pose3D(x, y, z0 + h / 2), True,
                            (Link("link", collisions=(Collision("c", Cylinder(r, h)),)),))


def sphere(name: str, x: float, y: float, z: float, r: float) -> ModelDescription:
    return ModelDescription(name, Pose3D(x, y, z), True, (Link("link", collisions=(Collision("c", Sphere(r)),)),))


def walls(xmin: float, ymin: float, xmax: float, ymax: float, t: float = 0.1) -> list[ModelDescription]:
    """Four walls of thickness t whose inner faces are the given rectangle."""
    cx, cy, w, h = (xmin + xmax) / 2, (ymin + ymax) / 2, xmax - xmin, ymax - ymin
    return [box("wall_s", cx, ymin - t / 2, w + 2 * t, t), box("wall_n", cx, ymax + t / 2, w + 2 * t, t),
            box("wall_w", xmin - t / 2, cy, t, h), box("wall_e", xmax + t / 2, cy, t, h)]


def two_rooms(door: float = 1.2) -> WorldDescription:
    """A 10 × 6 m hall split at x = 5 by a wall with a door of width `door` centred at y = 3."""
    half = (6.0 - door) / 2
    models = [*walls(0, 0, 10, 6),
              box("divider_s", 5, half / 2, 0.2, half), box("divider_n", 5, 6 - half / 2, 0.2, half),
              cylinder("pillar", 2.5, 3.0, 0.4), box("crate", 7.5, 1.5, 0.8, 0.8, yaw=0.6)]
    return WorldDescription("two_rooms", models=tuple(models))


def clutter(seed: int = 3, n: int = 25) -> WorldDescription:
    """A walled 12 × 12 m arena with n random cylinders and rotated boxes (fixed seed)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    models = list(walls(0, 0, 12, 12))
    for k in range(n):
        x, y = rng.uniform(1.5, 10.5, 2)
        if k % 2:
            models.append(cylinder(f"cyl{k}", x, y, float(rng.uniform(0.15, 0.45))))
        else:
            sx, sy = (float(v) for v in rng.uniform(0.3, 1.0, 2))
            models.append(box(f"box{k}", x, y, sx, sy, yaw=float(rng.uniform(0, 3))))
    return WorldDescription("clutter", models=tuple(models))
