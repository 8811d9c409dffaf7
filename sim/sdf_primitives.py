"""Building blocks for generated worlds: single-link static models (boxes, cylinders, spheres, walls),
visual-only markers, the ground plane and lights. Every model stands on the floor (z = 0).
"""

from __future__ import annotations

import math

from sim.sdf_shapes import DEFAULT_TEXTURE
from sim.types import (
    Box,
    Collision,
    Cylinder,
    Geometry,
    Light,
    Link,
    ModelDescription,
    Plane,
    Pose3D,
    Sphere,
    Visual,
)

RGBA = tuple[float, float, float, float]
WALL_RGBA: RGBA = (0.75, 0.72, 0.68, 1.0)
OBSTACLE_RGBA: RGBA = (0.8, 0.35, 0.15, 1.0)
GOAL_RGBA: RGBA = (0.1, 0.8, 0.2, 1.0)
DOCK_RGBA: RGBA = (0.15, 0.35, 0.9, 1.0)
FLOOR_TEXTURE = str(DEFAULT_TEXTURE)


def solid(name: str, geometry: Geometry, pose: Pose3D, rgba: RGBA = OBSTACLE_RGBA,
          material: str | None = None) -> ModelDescription:
    """A static one-link model whose collision and visual are the same shape."""
    link = Link("link", collisions=(Collision("collision", geometry),),
                visuals=(Visual("visual", geometry, rgba=rgba, material=material),))
    return ModelDescription(name, pose, True, (link,))


def box(name: str, size: tuple[float, float, float], x: float, y: float, yaw: float = 0.0,
        rgba: RGBA = OBSTACLE_RGBA, material: str | None = None) -> ModelDescription:
    return solid(name, Box(size), Pose3D(x, y, size[2] / 2, 0.0, 0.0, yaw), rgba, material)


def cylinder(name: str, radius: float, height: float, x: float, y: float, rgba: RGBA = OBSTACLE_RGBA,
             material: str | None = None) -> ModelDescription:
    return solid(name, Cylinder(radius, height), Pose3D(x, y, height / 2), rgba, material)


def sphere(name: str, radius: float, x: float, y: float, rgba: RGBA = OBSTACLE_RGBA,
           material: str | None = None) -> ModelDescription:
    """A ball resting on the floor (its top is at 2·radius)."""
    return solid(name, Sphere(radius), Pose3D(x, y, radius), rgba, material)


def wall(name: str, x0: float, y0: float, x1: float, y1: float, height: float = 1.0, thickness: float = 0.2,
         rgba: RGBA = WALL_RGBA) -> ModelDescription:
    """A straight wall whose centre line runs from (x0, y0) to (x1, y1)."""
    length = round(math.hypot(x1 - x0, y1 - y0), 9)
    yaw = math.atan2(y1 - y0, x1 - x0)
    cx, cy = round((x0 + x1) / 2, 9), round((y0 + y1) / 2, 9)
    return box(name, (length, thickness, height), cx, cy, yaw, rgba, "Gazebo/Bricks")


def enclosure(half_x: float, half_y: float, height: float = 1.0, thickness: float = 0.2,
              prefix: str = "wall") -> list[ModelDescription]:
    """Four walls whose inner faces are at x = ±half_x and y = ±half_y."""
    t = thickness / 2
    ox, oy = half_x + t, half_y + t
    return [wall(f"{prefix}_south", -ox - t, -oy, ox + t, -oy, height, thickness),
            wall(f"{prefix}_north", -ox - t, oy, ox + t, oy, height, thickness),
            wall(f"{prefix}_west", -ox, -oy + t, -ox, oy - t, height, thickness),
            wall(f"{prefix}_east", ox, -oy + t, ox, oy - t, height, thickness)]


def marker(name: str, x: float, y: float, rgba: RGBA = GOAL_RGBA, radius: float = 0.3,
           pole: float = 1.0) -> ModelDescription:
    """A visual-only marker (a disc on the floor and a thin pole): robots and lidar pass through it."""
    disc = Visual("disc", Cylinder(radius, 0.02), Pose3D(0, 0, 0.01), rgba)
    mast = Visual("pole", Cylinder(0.03, pole), Pose3D(0, 0, pole / 2), rgba)
    return ModelDescription(name, Pose3D(x, y, 0.0), True, (Link("link", visuals=(disc, mast)),))


def pad(name: str, x: float, y: float, yaw: float, size: tuple[float, float] = (1.0, 0.8),
        rgba: RGBA = DOCK_RGBA) -> ModelDescription:
    """A visual-only floor pad (e.g. a docking station footprint)."""
    v = Visual("pad", Box((size[0], size[1], 0.02)), Pose3D(0, 0, 0.01), rgba)
    return ModelDescription(name, Pose3D(x, y, 0.0, 0.0, 0.0, yaw), True, (Link("link", visuals=(v,)),))


def ground_plane(size: float = 100.0, material: str = "Gazebo/Grey",
                 rgba: RGBA = (0.85, 0.85, 0.85, 1.0)) -> ModelDescription:
    plane = Plane((0.0, 0.0, 1.0), (size, size))
    link = Link("link", collisions=(Collision("collision", plane, friction=1.0),),
                visuals=(Visual("visual", plane, rgba=rgba, material=material),))
    return ModelDescription("ground_plane", Pose3D(), True, (link,))


def sun() -> Light:
    return Light("sun", "directional", Pose3D(0, 0, 10), (0.8, 0.8, 0.8, 1.0), True, (-0.5, 0.1, -0.9))


def lamp(name: str, x: float, y: float, z: float = 3.0) -> Light:
    return Light(name, "point", Pose3D(x, y, z), (0.5, 0.5, 0.5, 1.0), False)
