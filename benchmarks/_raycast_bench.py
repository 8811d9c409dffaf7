"""Ray casters side by side on the same rays: Embree (sim/raycast_embree.py) and PyBullet rayTestBatch.

Embree keeps its static BVH from load and intersects the (kinematic) robots in closed form at their poses
(sim/raycast_robots.py): nothing is rebuilt per cast. The rays are exactly the ones the World's lidar casts in
one step of the sim_throughput scene (every robot's beams and their layout, recorded from World.cast_rays),
cast repeatedly through each side in alternation so all see the same machine load (wall and CPU time both
reported):

  embree    the lidar's call: the rays and their layout (one fan per robot, sim/raycast_layout.py)
  bare      Embree on the same bare rays, no layout (it recovers the fans from the rays: the path before 17c)
  rebuild   Embree with every moving body built into a scene per cast (the path before issue 17a; with movable
            models, the path before 17c), bare rays
  pybullet  rayTestBatch on the same rays (it has no use for a layout): the issue's baseline

Agreement is checked on the same rays: hit/miss and, where both hit the same body, range; and the layout's
result against the bare rays' (the same hits, ranges to float rounding).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from _sim_scene import Scene, make_scene, robot_spec

from sim import World, WorldDescription
from sim.raycast_layout import RayLayout
from sim.sdf_primitives import box, cylinder, sphere
from sim.sdf_writer import save_sdf


@dataclass
class CastResult:
    robots: int
    beams: int
    movable: int  # movable models in the scene (the engine steps; every robot is posed from PyBullet)
    rays: int
    embree_s: float  # wall seconds per cast of all rays (median)
    pybullet_s: float
    embree_cpu_s: float  # CPU seconds per cast (this process, all threads; mean): less sensitive to load
    pybullet_cpu_s: float
    bare_s: float  # Embree on the bare rays (no layout: before 17c), wall
    bare_cpu_s: float
    rebuild_s: float  # Embree with the robots built into a scene every cast (before issue 17a), wall
    rebuild_cpu_s: float
    hit_agree: float  # share of rays both call hit or both call miss
    median_mm: float  # |range difference| over rays where both hit the same body
    p99_mm: float
    layout_agree: float  # share of rays with the same uid with and without the layout
    layout_max_mm: float  # largest range difference between the two

    @property
    def ratio(self) -> float:
        return self.pybullet_s / self.embree_s

    @property
    def cpu_ratio(self) -> float:
        return self.pybullet_cpu_s / self.embree_cpu_s


def add_movable(world: World, scene: Scene, count: int) -> None:
    """`count` movable models (boxes, cylinders, spheres; physics moves them) midway between robots."""
    if count == 0:
        return
    with tempfile.TemporaryDirectory(prefix="fleetnav_movable_") as tmp:
        models = []
        for k, (x, y, _) in enumerate(scene.robots[:count].tolist()):
            shape = (box(f"m{k}", (0.5, 0.4, 0.5), x, y + 1.5, 0.3 * k), cylinder(f"m{k}", 0.25, 0.7, x, y + 1.5),
                     sphere(f"m{k}", 0.3, x, y + 1.5))[k % 3]
            link = replace(shape.links[0], mass=2.0, inertia=(0.1, 0, 0, 0.1, 0, 0.1))
            models.append(replace(shape, static=False, links=(link,)))
        path = Path(tmp) / "movable.world"
        save_sdf(WorldDescription(name="movable", models=tuple(models)), str(path))
        world.spawn_model(file=str(path))


def lidar_rays(n: int, beams: int, movable: int = 0) -> tuple[World, np.ndarray, np.ndarray, RayLayout]:
    """A kinematic world of `n` robots with `beams`-beam lidars (and `movable` movable models) and the rays
    (and layout) of one lidar sweep of all."""
    scene = make_scene(n)
    world = scene.world(physics_hz=10.0, fidelity="kinematic", spec=robot_spec(beams))
    add_movable(world, scene, movable)
    seen: list[tuple[np.ndarray, np.ndarray, RayLayout | None]] = []
    cast = world.cast_rays

    def record(origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        seen.append((origins.copy(), ends.copy(), layout))
        return cast(origins, ends, layout)

    world.cast_rays = record
    world.step()
    world.cast_rays = cast
    origins, ends, layout = seen[-1]
    assert layout is not None, "the lidar passes its layout"
    return world, origins, ends, layout


def compare(n: int, beams: int, wall_s: float, movable: int = 0) -> CastResult:
    world, o, e, layout = lidar_rays(n, beams, movable)
    # The same rays are cast again and again here: the fan cache (sim/raycast_fans.py, for robots standing still)
    # would serve every repeat from memory, so it is off and each side really casts every time.
    world.set_raycaster("embree")
    world.rays.embree.fans = None
    try:
        sides = ("embree", "bare", "rebuild", "pybullet")
        times: dict[str, list[float]] = {k: [] for k in sides}
        cpu: dict[str, float] = dict.fromkeys(sides, 0.0)
        out = {}

        def run(side: str) -> tuple[np.ndarray, np.ndarray]:
            world.set_raycaster("pybullet" if side == "pybullet" else "embree")
            if side != "pybullet":  # the Embree caster (and its static BVH) is kept across switches
                world.rays.embree.closed_form = side != "rebuild"
            return world.cast_rays(o, e, layout if side == "embree" else None)

        for side in sides:  # warm-up: static BVH, shape capture
            out[side] = run(side)
        start = time.perf_counter()
        while time.perf_counter() - start < wall_s or min(len(v) for v in times.values()) < 2:
            for side in sides:
                t, c = time.perf_counter(), time.process_time()
                run(side)
                times[side].append(time.perf_counter() - t)
                cpu[side] += time.process_time() - c
        world.set_raycaster("embree")
        world.rays.embree.closed_form = True
        (fe, ue), (fb, ub), (fp, up) = out["embree"], out["bare"], out["pybullet"]
        length = np.linalg.norm(e - o, axis=1)
        same = (ue >= 0) & (ue == up)
        err = np.abs(fe - fp)[same] * length[same] * 1e3

        def wall(side: str) -> float:
            return float(np.median(times[side]))

        def cpu_s(side: str) -> float:
            return cpu[side] / len(times[side])

        return CastResult(n, beams, movable, len(o), wall("embree"), wall("pybullet"), cpu_s("embree"),
                          cpu_s("pybullet"), wall("bare"), cpu_s("bare"), wall("rebuild"), cpu_s("rebuild"),
                          float(np.mean((ue >= 0) == (up >= 0))), float(np.median(err)) if err.size else 0.0,
                          float(np.percentile(err, 99)) if err.size else 0.0, float(np.mean(ue == ub)),
                          float(np.max(np.abs(fe - fb) * length)) * 1e3)
    finally:
        world.close()
