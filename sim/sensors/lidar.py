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
    """Cast the beams of every robot in `rows` (indices into `table`) in one batch and build scans. Rays are
    built in numpy per lidar model (robots of one model share a config); only the scans are per robot."""
    f = table.f
    rows = np.asarray(rows, dtype=np.int64)
    if rows.size == 0:
        return []
    groups: dict[tuple[float, ...], list[int]] = {}
    for k, i in enumerate(rows.tolist()):
        c = configs[i]
        groups.setdefault((c.angles.size, c.angle_min, c.angle_increment, c.range_min, c.range_max, c.height,
                           c.x_offset), []).append(k)
    origins, ends = [], []
    spans = np.zeros((rows.size, 2), dtype=np.int64)
    start = 0
    for ks in groups.values():
        idx = rows[ks]
        cfg = configs[int(idx[0])]
        yaw = f["yaw"][idx]
        ox, oy = f["x"][idx] + cfg.x_offset * np.cos(yaw), f["y"][idx] + cfg.x_offset * np.sin(yaw)
        wa = yaw[:, None] + cfg.angles[None, :]
        dirs = np.stack([np.cos(wa), np.sin(wa), np.zeros_like(wa)], axis=-1)  # (robots, beams, 3)
        base = np.stack([ox, oy, np.full(idx.size, cfg.height)], axis=-1)[:, None, :]
        # Rays start at range_min: a real lidar cannot see closer, and it keeps rays out of its own housing.
        origins.append((base + dirs * cfg.range_min).reshape(-1, 3))
        ends.append((base + dirs * cfg.range_max).reshape(-1, 3))
        nb = cfg.angles.size
        spans[ks, 0] = start + nb * np.arange(idx.size)
        spans[ks, 1] = spans[ks, 0] + nb
        start += nb * idx.size
    fractions, uids = cast(np.concatenate(origins), np.concatenate(ends))
    scans = []
    for (a, b), i in zip(spans.tolist(), rows.tolist(), strict=True):
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
