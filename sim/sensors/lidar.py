"""2D lidar: every due robot's beams go into one batched ray cast (split ≤ 16,000 rays per call)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.robot_spec import RobotSpec
from sim.robot_table import RobotTable
from sim.types import LidarScan

RayCaster = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class LidarConfig:
    """The per-model constants of a lidar; robots of one model share one config (and one angle array)."""

    angles: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    height: float
    x_offset: float

    @staticmethod
    def from_spec(spec: RobotSpec) -> LidarConfig:
        ls = spec.sensors.lidar
        inc = math.radians(ls.fov_deg) / ls.beams
        amin = -math.pi if ls.fov_deg >= 360 else -math.radians(ls.fov_deg) / 2
        angles = amin + inc * np.arange(ls.beams)
        return LidarConfig(angles, amin, inc, ls.range_min, ls.range_max, spec.lidar_height,
                           spec.mast.x_offset)


def cast_scans(table: RobotTable, rows: np.ndarray, configs: list[LidarConfig], cast: RayCaster,
               rng: np.random.Generator, stamp: float) -> list[LidarScan]:
    """Cast the beams of every robot in `rows` (indices into `table`) in one batch and build scans."""
    f = table.f
    origins, ends, spans = [], [], []
    start = 0
    for i in rows:
        cfg = configs[i]
        c, s = math.cos(f["yaw"][i]), math.sin(f["yaw"][i])
        ox, oy = f["x"][i] + cfg.x_offset * c, f["y"][i] + cfg.x_offset * s
        world_angles = cfg.angles + f["yaw"][i]
        dirs = np.column_stack([np.cos(world_angles), np.sin(world_angles), np.zeros(world_angles.size)])
        base = np.array([ox, oy, cfg.height])
        # Rays start at range_min: a real lidar cannot see closer, and it keeps rays out of its own housing.
        origins.append(base + dirs * cfg.range_min)
        ends.append(base + dirs * cfg.range_max)
        spans.append((start, start + cfg.angles.size))
        start += cfg.angles.size
    if not spans:
        return []
    fractions, uids = cast(np.concatenate(origins), np.concatenate(ends))
    scans = []
    for (a, b), i in zip(spans, rows, strict=True):
        cfg = configs[i]
        hit = uids[a:b] >= 0
        ranges = cfg.range_min + fractions[a:b] * (cfg.range_max - cfg.range_min)
        sigma = f["lidar_noise_std"][i] * f["lidar_noise_scale"][i]
        if sigma > 0:
            ranges = ranges + rng.normal(0.0, sigma, ranges.size)
        ranges = np.where(hit & (ranges >= cfg.range_min) & (ranges <= cfg.range_max), ranges, np.inf)
        scans.append(LidarScan(table.names[i], stamp, cfg.angle_min, cfg.angle_increment, cfg.range_min,
                               cfg.range_max, ranges, uids[a:b].copy()))
    return scans
