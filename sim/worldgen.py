"""Deterministic world generators: a cluttered arena with a guaranteed corridor, and a shelf warehouse.

Every obstacle is ≥ 0.8 m tall so the robot's lidar (≈ 0.57 m above the floor) sees it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.sdf_paths import DEFAULT_MODEL_DIR
from sim.sdf_primitives import (
    FLOOR_TEXTURE,
    box,
    cylinder,
    enclosure,
    ground_plane,
    lamp,
    marker,
    pad,
    sun,
)
from sim.types import Link, ModelDescription, Pose2D, Pose3D, SpawnPoint, WorldDescription

CORRIDOR_WIDTH = 1.6  # free corridor kept from start to goal (a 0.34 m robot needs ≥ 0.68 m)
SHELF_URI = "model://warehouse_shelf"
SHELF_SIZE = (2.4, 0.9)  # footprint of configs/models/warehouse_shelf


def _seg_distance(px: float, py: float, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    t = float(np.clip(np.dot((px, py) - a, ab) / max(float(np.dot(ab, ab)), 1e-12), 0.0, 1.0))
    return float(np.hypot(*((px, py) - (a + t * ab))))


def cluttered_arena(seed: int, difficulty: int, size: float = 10.0) -> WorldDescription:
    """A walled size × size arena with random boxes and cylinders, a start spawn point in the south-west
    corner, a `goal_marker` in the north-east one, and a free corridor (1.6 m wide) joining them.
    Difficulty 1..5 raises the obstacle density from ≈ 0.035 to ≈ 0.135 obstacles per m²."""
    if not 1 <= difficulty <= 5:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"difficulty must be 1..5, got {difficulty}")
    if size < 4.0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"size must be ≥ 4 m, got {size}")
    rng = np.random.default_rng(seed)
    h = size / 2
    start, goal = np.array([-h + 1.0, -h + 1.0]), np.array([h - 1.0, h - 1.0])
    # The corridor: start → two random waypoints → goal; obstacles keep clear of it.
    mids = [rng.uniform(-h + 1.5, h - 1.5, 2) for _ in range(2)]
    path = [start, *mids, goal]
    wanted = round((0.025 * difficulty + 0.01) * size * size)
    placed: list[tuple[float, float, float]] = []  # (x, y, bounding radius)
    models: list[ModelDescription] = [ground_plane(material="Gazebo/Grey"), *enclosure(h, h, 1.0)]
    for _ in range(wanted * 60):
        if len(placed) >= wanted:
            break
        is_box = bool(rng.random() < 0.5)
        height = round(float(rng.uniform(0.8, 1.5)), 3)
        if is_box:
            sx, sy = (round(float(v), 3) for v in rng.uniform(0.4, 1.2, 2))
            yaw = round(float(rng.uniform(-math.pi, math.pi)), 4)
            r = 0.5 * math.hypot(sx, sy)
        else:
            r = round(float(rng.uniform(0.2, 0.6)), 3)
        x, y = (round(float(v), 3) for v in rng.uniform(-h + r, h - r, 2))
        clear = min(_seg_distance(x, y, a, b) for a, b in itertools.pairwise(path))
        if clear < CORRIDOR_WIDTH / 2 + r or any(math.hypot(x - ox, y - oy) < r + orr for ox, oy, orr in placed):
            continue
        name = f"obstacle_{len(placed)}"
        models.append(box(name, (sx, sy, height), x, y, yaw) if is_box else cylinder(name, r, height, x, y))
        placed.append((x, y, r))
    models.append(marker("goal_marker", float(goal[0]), float(goal[1])))
    return WorldDescription(
        name=f"cluttered_arena_s{seed}_d{difficulty}", models=tuple(models), lights=(sun(), lamp("lamp", 0, 0)),
        spawn_points=(SpawnPoint("spawn_start", Pose2D(float(start[0]), float(start[1]), math.pi / 4)),),
        ground_material=FLOOR_TEXTURE)


def shelf_links() -> tuple[Link, ...]:
    """The links of configs/models/warehouse_shelf, read from its SDF file (the one source of truth)."""
    from sim.sdf_parser import parse_sdf

    return parse_sdf(DEFAULT_MODEL_DIR / "warehouse_shelf" / "model.sdf").models[0].links


def warehouse(size: float = 40.0, aisle_width: float = 2.6, cross_aisle: float = 3.0,
              shelves_per_block: int = 4) -> WorldDescription:
    """A size × size warehouse: outer walls, back-to-back shelf rows (`model://warehouse_shelf`) with
    aisles of `aisle_width` between row pairs and cross aisles between blocks, and a free loading band
    along the south wall holding docks (`dock_*` markers) and spawn points (`spawn_*`)."""
    if aisle_width < 2.0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"aisle_width must be ≥ 2 m, got {aisle_width}")
    if size < 20.0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"size must be ≥ 20 m, got {size}")
    h = size / 2
    links = shelf_links()
    sl, sd = SHELF_SIZE
    block = shelves_per_block * sl
    n_blocks = max(1, int((size - 2 * 2.5 + cross_aisle) // (block + cross_aisle)))
    x0 = -(n_blocks * block + (n_blocks - 1) * cross_aisle) / 2
    y_first, y_top = -h + 6.0 + sd, h - 2.5 - sd  # pair centre lines: 6 m loading band, 2.5 m north aisle
    pairs = int((y_top - y_first) // (2 * sd + aisle_width)) + 1
    models: list[ModelDescription] = [ground_plane(material="Gazebo/Grey"), *enclosure(h, h, 3.0)]
    for pi in range(pairs):
        yc = y_first + pi * (2 * sd + aisle_width)
        for side, dy in (("a", -sd / 2), ("b", sd / 2)):
            for bi in range(n_blocks):
                for si in range(shelves_per_block):
                    x = x0 + bi * (block + cross_aisle) + (si + 0.5) * sl
                    pose = Pose3D(round(x, 6), round(yc + dy, 6))
                    models.append(ModelDescription(f"shelf_{pi}{side}_{bi}_{si}", pose, True, links, SHELF_URI))
    stations = np.linspace(-h + 4.0, h - 4.0, 4)
    spawns = []
    for i, x in enumerate(stations, start=1):
        xr = round(float(x), 2)
        models.append(pad(f"dock_{i}", xr, -h + 1.0, math.pi / 2))
        spawns.append(SpawnPoint(f"spawn_{i}", Pose2D(xr, -h + 3.5, math.pi / 2)))
    lights = (sun(), *(lamp(f"lamp_{i}", round(float(x), 2), 0.0, 6.0) for i, x in enumerate(stations, 1)))
    return WorldDescription(name="warehouse", models=tuple(models), lights=lights, spawn_points=tuple(spawns),
                            ground_material=FLOOR_TEXTURE)
