"""The worlds shipped in configs/worlds/, as code, and the script that (re)writes them.

    .venv/bin/python -m sim.sdf_shipped configs/worlds

`robot_arena` is the course's Module 2 world (12 m × 12 m inside its walls, a three-lane serpentine maze
whose lanes are ≥ 1.9 m wide, boxes, cylinders and spheres in the lanes, start spawn point in the
south-west, goal marker in the north-east). Tests load the written files, not these functions.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
from PIL import Image

from sim.sdf_primitives import (
    FLOOR_TEXTURE,
    box,
    cylinder,
    enclosure,
    ground_plane,
    lamp,
    marker,
    sphere,
    sun,
    wall,
)
from sim.sdf_writer import save_sdf
from sim.types import Light, Pose2D, SpawnPoint, WorldDescription
from sim.worldgen import warehouse

ARENA_HALF = 6.0


def robot_arena() -> WorldDescription:
    h = ARENA_HALF
    barriers = [
        wall("barrier_south", -h, -2.5, 2.6, -2.5),  # lane 1 (south) opens to lane 2 in the east
        wall("barrier_north", -2.6, 1.5, h, 1.5),  # lane 2 (middle) opens to lane 3 in the west
        wall("stub_south", -1.0, -h, -1.0, -4.6),  # narrows lane 1 to 2.0 m
        wall("stub_north", 2.0, h, 2.0, 3.5),  # narrows lane 3 to 1.9 m
    ]
    obstacles = [
        box("box_crate", (0.8, 0.8, 1.0), -3.5, -4.2, 0.0, (0.6, 0.4, 0.2, 1.0), "Gazebo/Wood"),
        cylinder("cylinder_barrel", 0.35, 1.2, 1.5, -4.6, (0.1, 0.3, 0.8, 1.0), "Gazebo/Blue"),
        sphere("sphere_ball", 0.45, 4.3, -0.5, (0.9, 0.1, 0.1, 1.0), "Gazebo/Red"),
        box("box_diamond", (0.7, 0.7, 1.0), 0.0, -0.4, math.pi / 4, (0.9, 0.6, 0.1, 1.0), "Gazebo/Orange"),
        cylinder("cylinder_pillar", 0.3, 1.0, -4.0, 0.3, (0.5, 0.5, 0.5, 1.0), "Gazebo/Grey"),
        sphere("sphere_boulder", 0.4, -0.5, 3.8, (0.4, 0.4, 0.35, 1.0), "Gazebo/DarkGrey"),
        box("box_long", (1.2, 0.6, 0.9), 4.0, 2.6, 0.0, (0.2, 0.6, 0.3, 1.0), "Gazebo/Green"),
    ]
    lights: tuple[Light, ...] = (sun(), lamp("lamp_west", -3.0, 0.0, 4.0), lamp("lamp_east", 3.0, 0.0, 4.0))
    return WorldDescription(
        name="robot_arena",
        models=(ground_plane(material="Gazebo/WoodFloor"), *enclosure(h, h, 1.0), *barriers, *obstacles,
                marker("goal_marker", 5.0, 5.0)),
        lights=lights, spawn_points=(SpawnPoint("spawn_start", Pose2D(-5.0, -5.0, 0.0)),),
        ground_material=FLOOR_TEXTURE)


def empty_world() -> WorldDescription:
    return WorldDescription(name="empty", models=(ground_plane(material="Gazebo/Grey"),), lights=(sun(),),
                            spawn_points=(SpawnPoint("spawn_origin", Pose2D(0.0, 0.0, 0.0)),),
                            ground_material=FLOOR_TEXTURE)


def floor_texture(px: int = 128, tiles: int = 2) -> np.ndarray:
    """A light-grey tile pattern with darker grout and faint deterministic speckle (RGB uint8)."""
    rng = np.random.default_rng(0)
    img = np.full((px, px, 3), 200.0)
    img += rng.normal(0.0, 6.0, (px, px, 1))
    cell = px // tiles
    idx = np.arange(px)
    grout = (idx % cell < 2) | (idx % cell >= cell - 2)
    img[grout, :, :] = 120.0
    img[:, grout, :] = 120.0
    checker = ((idx[:, None] // cell + idx[None, :] // cell) % 2 == 1) & ~grout[:, None] & ~grout[None, :]
    img[checker] -= 25.0
    return np.clip(img, 0, 255).astype(np.uint8)


def write_all(out_dir: Path) -> list[Path]:
    tex = Path(FLOOR_TEXTURE)
    tex.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(floor_texture()).save(tex)
    written = []
    for fname, world, note in (
        ("robot_arena.world", robot_arena(), "Course Module 2 arena: 12 x 12 m maze; regenerate with "
         "`python -m sim.sdf_shipped configs/worlds`"),
        ("empty.world", empty_world(), "Empty world: ground plane, sun, a spawn point at the origin"),
        ("warehouse.world", warehouse(), "40 x 40 m warehouse: shelf rows included from "
         "model://warehouse_shelf, docks dock_*, spawn points spawn_*"),
    ):
        path = out_dir / fname
        save_sdf(world, path, comment=note)
        written.append(path)
    return written


if __name__ == "__main__":
    for p in write_all(Path(sys.argv[1] if len(sys.argv) > 1 else "configs/worlds")):
        print(p)
