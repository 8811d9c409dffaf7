"""One benchmark configuration: our World, and raw PyBullet doing the same work step by step on a twin.

The clock covers what a user's loop pays per step: the driver's commands and `World.step()` (limits,
motion, collision resolution, physics, sensors). After each of our steps, raw PyBullet does the same step's
work on a twin client (see _raw_pybullet.py); checks (moved share, overlaps) run outside both clocks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from _raw_pybullet import RawBaseline
from _sim_driver import ArcDriver
from _sim_scene import Scene, robot_spec

from sim.kinematic_collisions import penetrating_contacts
from sim.types import Fidelity, LidarScan

WARMUP_STEPS = 3
RAYCASTER = "embree"  # our World's ray caster (sim_throughput.py --raycaster)


@dataclass(frozen=True)
class Config:
    drive: Fidelity
    robots: int
    beams: int | None  # lidar beams; None: lidar off
    physics_hz: float

    @property
    def label(self) -> str:
        return f"{self.drive} {'no lidar' if self.beams is None else f'lidar {self.beams}'} @{self.physics_hz:g} Hz"


@dataclass(frozen=True)
class Budget:
    min_steps: int
    max_steps: int
    wall_s: float  # stop after this much timed wall time once min_steps are done


@dataclass
class Result:
    config: Config
    steps: int
    wall_s: float  # timed: driver + World.step
    cpu_s: float  # this process's CPU time over the same region (all its threads): less sensitive to load
    setup_s: float
    rays: int  # lidar rays cast during the timed steps
    moved: float  # mean share of robots whose pose changed per step
    blocked: float  # mean robots blocked (collision resolved by reverting) per step
    overlaps_end: int  # penetrating pairs after the last step, as the World's own query sees them (must be 0)
    raw_step_s: float  # raw PyBullet seconds per step for the same work (lidar casts included)
    raw_motion_cpu_s: float  # raw PyBullet CPU seconds per step of the motion step alone (lidar casts excluded)
    raw_overlap_steps: int  # steps after which a pair penetrates, by fresh getClosestPoints (must be 0)
    raw_rays_per_s: float  # raw rayTestBatch throughput on the same scene (0 when lidar is off)

    @property
    def sim_s(self) -> float:
        return self.steps / self.config.physics_hz

    @property
    def rtf(self) -> float:
        return self.sim_s / self.wall_s

    @property
    def rtf_cpu(self) -> float:
        return self.sim_s / self.cpu_s

    @property
    def robot_steps_per_s(self) -> float:
        return self.config.robots * self.steps / self.wall_s

    @property
    def step_s(self) -> float:
        return self.wall_s / self.steps

    @property
    def rays_per_s(self) -> float:
        return self.rays / self.wall_s


class RayCounter:
    """A scan subscriber, as a real consumer would be: counts the rays of every scan the world publishes."""

    def __init__(self) -> None:
        self.rays = 0

    def __call__(self, reading: object) -> None:
        if isinstance(reading, LidarScan):
            self.rays += reading.ranges.size


def run_config(cfg: Config, scene: Scene, budget: Budget) -> Result:
    spec = robot_spec(cfg.beams)
    t0 = time.perf_counter()
    world = scene.world(physics_hz=cfg.physics_hz, fidelity=cfg.drive, spec=spec)
    world.set_raycaster(RAYCASTER)
    setup_s = time.perf_counter() - t0
    twin = scene.world(physics_hz=cfg.physics_hz, fidelity=cfg.drive, spec=spec)  # raw PyBullet's copy
    try:
        driver, raw = ArcDriver(world), RawBaseline(twin)
        f = world.table.f  # read-only fleet state: poses for the raw replay, setpoints, the moved share
        for _ in range(WARMUP_STEPS):
            driver.update()
            world.step()
            _raw_step(cfg, raw, f)
        raw.cpu_s = 0.0
        rays = RayCounter()
        world.subscribe(rays, kinds=("scan",))
        prev = _pose(f)
        steps, wall, cpu, moved, blocked = 0, 0.0, 0.0, 0.0, 0
        raw_wall, raw_lidar_wall, raw_rays, overlap_steps = 0.0, 0.0, 0, 0
        while steps < budget.max_steps and (steps < budget.min_steps or wall < budget.wall_s):
            cast_before = rays.rays
            t, c = time.perf_counter(), time.process_time()
            blocked += driver.update()
            world.step()
            wall += time.perf_counter() - t
            cpu += time.process_time() - c
            steps += 1
            cur = _pose(f)
            moved += float(np.mean(np.any(cur != prev, axis=1)))
            prev = cur
            raw_wall += _raw_step(cfg, raw, f)  # the same step's work on raw PyBullet, right after ours
            if cfg.drive == "kinematic":
                overlap_steps += raw.penetrating_pairs(cur) > 0  # checked afresh on the twin at our poses
            if rays.rays > cast_before:
                dt, n = raw.lidar_cast(cur if cfg.drive == "kinematic" else raw.robot_poses())
                raw_lidar_wall, raw_rays = raw_lidar_wall + dt, raw_rays + n
        overlaps = len(penetrating_contacts(world)) if cfg.drive == "kinematic" else 0
        return Result(cfg, steps, wall, cpu, setup_s, rays.rays, moved / steps, blocked / steps, overlaps,
                      (raw_wall + raw_lidar_wall) / steps, raw.cpu_s / steps, overlap_steps,
                      raw_rays / raw_lidar_wall if raw_lidar_wall else 0.0)
    finally:
        world.close()
        twin.close()


def _pose(f: dict[str, np.ndarray]) -> np.ndarray:
    return np.column_stack([f["x"], f["y"], f["yaw"]])


def _raw_step(cfg: Config, raw: RawBaseline, f: dict[str, np.ndarray]) -> float:
    """Kinematic: replay our poses (the twin's robots move exactly as ours did). Dynamic: the same motor
    targets (the twin's robots then move under their own physics, as ours do)."""
    if cfg.drive == "kinematic":
        return raw.kinematic_step(_pose(f))
    return raw.dynamic_step(f["sp_v"], f["sp_w"])
