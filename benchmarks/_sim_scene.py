"""The one scene every side of the sim throughput benchmark runs: ours, raw PyBullet and the peer.

An open walled area with robots on a 3 m grid (random headings) and static obstacles (boxes and cylinders,
1 m tall so the lidar sees them) on ~10% of the grid's inner corners, i.e. between four robots. For 1000
robots that is a 96 m × 96 m floor, 9 m² per robot, ~96 obstacles: warehouse-like density.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sim import Pose2D, RobotSpec, World, WorldDescription, default_robot_path, load_robot_spec
from sim.sdf_primitives import box, cylinder, enclosure, ground_plane
from sim.sdf_writer import save_sdf
from sim.types import Box, Fidelity

SPACING = 3.0  # m between neighbouring robots at spawn
MIN_HALF = 10.0  # m: small fleets still get a 20 m × 20 m room (something for the lidar to see)
OBSTACLE_SHARE = 0.10  # of the grid's inner corners
WALL_HEIGHT = 1.0


@dataclass(frozen=True)
class Obstacle:
    name: str
    kind: str  # "box" | "cylinder"
    x: float
    y: float
    yaw: float
    sx: float = 0.0  # box size
    sy: float = 0.0
    r: float = 0.0  # cylinder radius
    h: float = WALL_HEIGHT


@dataclass(frozen=True)
class Scene:
    robots: np.ndarray  # (n, 3): x, y, yaw at spawn
    obstacles: tuple[Obstacle, ...]  # inner obstacles and the four walls (as boxes)
    half: float  # the walls' inner faces are at ±half

    def description(self) -> WorldDescription:
        models = [ground_plane(size=4 * self.half)]
        for o in self.obstacles:
            models.append(box(o.name, (o.sx, o.sy, o.h), o.x, o.y, o.yaw) if o.kind == "box"
                          else cylinder(o.name, o.r, o.h, o.x, o.y))
        return WorldDescription(name="sim_throughput", models=tuple(models))

    def world(self, *, physics_hz: float, fidelity: Fidelity, spec: RobotSpec, seed: int = 0) -> World:
        """A World holding this scene (loaded from an SDF file, as a user would) and its robots."""
        with tempfile.TemporaryDirectory(prefix="fleetnav_bench_") as tmp:
            path = Path(tmp) / "scene.world"
            save_sdf(self.description(), str(path))
            world = World.from_sdf(path, physics_hz=physics_hz, fidelity=fidelity, seed=seed)
        for k, (x, y, yaw) in enumerate(self.robots.tolist()):
            # The grid is collision-free by construction (checked after each run); skipping the per-spawn
            # overlap query keeps set-up O(n) instead of O(n²).
            world.spawn_robot(f"r{k}", Pose2D(x, y, yaw), spec=spec, check_collision=False)
        return world

    def peer_json(self) -> dict[str, Any]:
        return {"robots": self.robots.tolist(), "half": self.half,
                "obstacles": [o.__dict__ for o in self.obstacles]}


def make_scene(n: int, seed: int = 0) -> Scene:
    rng = np.random.default_rng(seed)
    side = max(1, math.ceil(math.sqrt(n)))
    half = max(side * SPACING / 2, MIN_HALF)
    lo = -side * SPACING / 2
    k = np.arange(n)
    xy = np.column_stack([lo + SPACING * (k // side + 0.5), lo + SPACING * (k % side + 0.5)])
    robots = np.column_stack([xy, rng.uniform(-math.pi, math.pi, n)])
    corners = [(lo + SPACING * (i + 1), lo + SPACING * (j + 1)) for i in range(side - 1) for j in range(side - 1)]
    count = round(OBSTACLE_SHARE * len(corners))
    obstacles: list[Obstacle] = []
    for idx in rng.choice(len(corners), size=count, replace=False) if count else []:
        x, y = corners[int(idx)]
        name = f"obstacle_{len(obstacles)}"
        if rng.random() < 0.5:  # corner-to-robot distance is 2.12 m: these never touch a spawn pose
            sx, sy = (float(v) for v in rng.uniform(0.6, 1.2, 2))
            obstacles.append(Obstacle(name, "box", x, y, float(rng.uniform(-math.pi, math.pi)), sx=sx, sy=sy))
        else:
            obstacles.append(Obstacle(name, "cylinder", x, y, 0.0, r=float(rng.uniform(0.3, 0.6))))
    for m in enclosure(half, half, WALL_HEIGHT):
        wall = m.links[0].collisions[0].geometry
        assert isinstance(wall, Box)
        size = wall.size
        obstacles.append(Obstacle(m.name, "box", m.pose.x, m.pose.y, m.pose.yaw, sx=size[0], sy=size[1]))
    return Scene(robots, tuple(obstacles), half)


def robot_spec(beams: int | None) -> RobotSpec:
    """The course robot (configs/robots/diffbot.yaml) with its lidar off (None) or at `beams` beams."""
    spec = load_robot_spec(default_robot_path())
    lidar = spec.sensors.lidar.model_copy(update={"enabled": beams is not None, "beams": beams or 360})
    return spec.model_copy(update={"sensors": spec.sensors.model_copy(update={"lidar": lidar})})
