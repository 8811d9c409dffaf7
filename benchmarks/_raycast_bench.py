"""Ray casters side by side on the same rays: Embree (sim/raycast_embree.py) and PyBullet rayTestBatch.

Embree keeps its static BVH from load and intersects the (kinematic) robots in closed form at their poses
(sim/raycast_robots.py): nothing is rebuilt per cast. The rays are exactly the ones the World's lidar casts in
one step of the sim_throughput scene (every robot's beams, recorded from World.cast_rays), cast repeatedly
through each backend in alternation so both see the same machine load (wall and CPU time both reported).
Agreement is checked on the same rays: hit/miss and, where both hit the same body, range.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from _sim_scene import make_scene, robot_spec

from sim import World


@dataclass
class CastResult:
    robots: int
    beams: int
    rays: int
    embree_s: float  # wall seconds per cast of all rays (median)
    pybullet_s: float
    embree_cpu_s: float  # CPU seconds per cast (this process, all threads; mean): less sensitive to load
    pybullet_cpu_s: float
    rebuild_s: float  # Embree with the robots built into a scene every cast (before issue 17a), wall
    rebuild_cpu_s: float
    hit_agree: float  # share of rays both call hit or both call miss
    median_mm: float  # |range difference| over rays where both hit the same body
    p99_mm: float

    @property
    def ratio(self) -> float:
        return self.pybullet_s / self.embree_s

    @property
    def cpu_ratio(self) -> float:
        return self.pybullet_cpu_s / self.embree_cpu_s


def lidar_rays(n: int, beams: int) -> tuple[World, np.ndarray, np.ndarray]:
    """A kinematic world of `n` robots with `beams`-beam lidars and the rays of one lidar sweep of all."""
    world = make_scene(n).world(physics_hz=10.0, fidelity="kinematic", spec=robot_spec(beams))
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    cast = world.cast_rays

    def record(origins: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        seen.append((origins.copy(), ends.copy()))
        return cast(origins, ends)

    world.cast_rays = record
    world.step()
    world.cast_rays = cast
    origins, ends = seen[-1]
    return world, origins, ends


def compare(n: int, beams: int, wall_s: float) -> CastResult:
    world, o, e = lidar_rays(n, beams)
    try:
        sides = ("embree", "rebuild", "pybullet")  # rebuild: Embree with the robots built every cast (before 17a)
        times: dict[str, list[float]] = {k: [] for k in sides}
        cpu: dict[str, float] = dict.fromkeys(sides, 0.0)
        out = {}

        def use(side: str) -> None:
            world.set_raycaster("pybullet" if side == "pybullet" else "embree")
            if side != "pybullet":  # the Embree caster (and its static BVH) is kept across switches
                world.rays.embree.closed_form = side == "embree"

        for side in sides:  # warm-up: static BVH, shape capture
            use(side)
            out[side] = world.cast_rays(o, e)
        start = time.perf_counter()
        while time.perf_counter() - start < wall_s or min(len(v) for v in times.values()) < 2:
            for side in sides:
                use(side)
                t, c = time.perf_counter(), time.process_time()
                world.cast_rays(o, e)
                times[side].append(time.perf_counter() - t)
                cpu[side] += time.process_time() - c
        use("embree")
        (fe, ue), (fp, up) = out["embree"], out["pybullet"]
        length = np.linalg.norm(e - o, axis=1)
        same = (ue >= 0) & (ue == up)
        err = np.abs(fe - fp)[same] * length[same] * 1e3
        return CastResult(n, beams, len(o), float(np.median(times["embree"])), float(np.median(times["pybullet"])),
                          cpu["embree"] / len(times["embree"]), cpu["pybullet"] / len(times["pybullet"]),
                          float(np.median(times["rebuild"])), cpu["rebuild"] / len(times["rebuild"]),
                          float(np.mean((ue >= 0) == (up >= 0))), float(np.median(err)) if err.size else 0.0,
                          float(np.percentile(err, 99)) if err.size else 0.0)
    finally:
        world.close()
