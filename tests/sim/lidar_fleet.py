"""A small kinematic lidar fleet shared by the ray-casting tests: ten robots with 360-beam lidars among static boxes
and a cylinder (no movable model, so the robots go through the upright closed form); every third one drives."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sim import Pose2D, World
from sim.sdf_primitives import box, cylinder, ground_plane
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription


def lidar_fleet(folder: Path, name: str, world_seed: int, heading_seed: int) -> World:
    models = [ground_plane(size=40), box("wall", (0.3, 9.0, 1.0), 4.5, 0.0),
              box("crate", (0.8, 0.5, 1.0), -2.0, 2.5, 0.4), cylinder("post", 0.25, 1.0, 1.0, -2.5)]
    path = folder / f"{name}.world"
    save_sdf(WorldDescription(name=name, models=tuple(models)), str(path))
    w = World.from_sdf(Path(path), physics_hz=10.0, fidelity="kinematic", seed=world_seed)
    rng = np.random.default_rng(heading_seed)
    for k in range(10):
        w.spawn_robot(f"r{k}", Pose2D(-3.0 + 1.4 * (k % 5), -1.2 + 2.0 * (k // 5), float(rng.uniform(-3, 3))))
    for k in range(0, 10, 3):
        w.set_cmd_vel(f"r{k}", 0.3, 0.5)
    return w
