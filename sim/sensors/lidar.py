"""2D lidar: every due robot's beams go into one batched ray cast (split ≤ 16,000 rays per call), with their
layout (one fan per robot: centre, first heading, step, ranges) so the caster need not recover it from the
rays; ranges, noise and validity are computed over all rays at once."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sim.raycast_layout import RayLayout
from sim.robot_spec import RobotSpec
from sim.robot_table import RobotTable
from sim.types import LidarScan


class RayCaster(Protocol):
    """World.cast_rays: (fraction, uid) per ray; `layout` describes the rays (a backend may ignore it)."""

    def __call__(self, origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
                 ) -> tuple[np.ndarray, np.ndarray]: ...


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
        """The one config object of these values: robots with equal lidars share it, so a step's rays are
        grouped by object identity without comparing values robot by robot."""
        ls = spec.sensors.lidar
        key = (ls.beams, float(ls.fov_deg), float(ls.range_min), float(ls.range_max), float(spec.lidar_height),
               float(spec.mast.x_offset))
        if key not in _SHARED:
            inc = math.radians(ls.fov_deg) / ls.beams
            amin = -math.pi if ls.fov_deg >= 360 else -math.radians(ls.fov_deg) / 2
            angles = amin + inc * np.arange(ls.beams)
            angles.setflags(write=False)
            _SHARED[key] = LidarConfig(angles, amin, inc, ls.range_min, ls.range_max, spec.lidar_height,
                                       spec.mast.x_offset)
        return _SHARED[key]


_SHARED: dict[tuple[float, ...], LidarConfig] = {}


def cast_scans(table: RobotTable, rows: np.ndarray, configs: list[LidarConfig], cast: RayCaster,
               rng: np.random.Generator, stamp: float) -> list[LidarScan]:
    """Cast the beams of every robot in `rows` (indices into `table`) in one batch and build scans. Rays are
    built in numpy per lidar model (robots of one model share a config); only the scans are per robot."""
    f = table.f
    rows = np.asarray(rows, dtype=np.int64)
    if rows.size == 0:
        return []
    cfgs = [configs[i] for i in rows.tolist()]
    _, which = np.unique(np.array([id(c) for c in cfgs], dtype=np.int64), return_inverse=True)
    groups = [np.flatnonzero(which.ravel() == g) for g in range(int(which.max()) + 1)]
    n_rays = sum(int(configs[int(rows[ks[0]])].angles.size) * ks.size for ks in groups)
    origins, ends = np.empty((n_rays, 3)), np.empty((n_rays, 3))
    spans = np.zeros((rows.size, 2), dtype=np.int64)
    fan = np.empty((rows.size, 7))  # per robot: centre x, y, z, first heading, step, range_min, range_max
    start = 0
    for ks in groups:
        idx = rows[ks]
        cfg = configs[int(idx[0])]
        nb = cfg.angles.size
        yaw = f["yaw"][idx]
        cy, sy = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        ca, sa = np.cos(cfg.angles)[None, :], np.sin(cfg.angles)[None, :]
        dx, dy = cy * ca - sy * sa, sy * ca + cy * sa  # (robots, beams): cos and sin of yaw + beam angle
        ox, oy = f["x"][idx][:, None] + cfg.x_offset * cy, f["y"][idx][:, None] + cfg.x_offset * sy
        block = slice(start, start + nb * idx.size)
        # Rays start at range_min: a real lidar cannot see closer, and it keeps rays out of its own housing.
        for out, r in ((origins, cfg.range_min), (ends, cfg.range_max)):
            out[block, 0] = (ox + r * dx).ravel()
            out[block, 1] = (oy + r * dy).ravel()
            out[block, 2] = cfg.height
        spans[ks, 0] = start + nb * np.arange(idx.size)
        spans[ks, 1] = spans[ks, 0] + nb
        fan[ks] = np.column_stack([ox[:, 0], oy[:, 0], np.full(idx.size, cfg.height), yaw + float(cfg.angles[0]),
                                   np.full(idx.size, cfg.angle_increment), np.full(idx.size, cfg.range_min),
                                   np.full(idx.size, cfg.range_max)])
        start += nb * idx.size
    beams = spans[:, 1] - spans[:, 0]
    by_start = np.argsort(spans[:, 0], kind="stable")  # the robots' ray blocks in ray order
    fs = fan[by_start]
    layout = RayLayout(spans[by_start, 0], beams[by_start], fs[:, 0], fs[:, 1], fs[:, 2], fs[:, 3], fs[:, 4],
                       fs[:, 5], fs[:, 6])
    fractions, uids = cast(origins, ends, layout=layout)
    # Ranges, noise and validity for every ray at once; only the scan objects are per robot.
    ray_k = np.repeat(by_start, beams[by_start])
    rmin = np.array([c.range_min for c in cfgs])[ray_k]
    rmax = np.array([c.range_max for c in cfgs])[ray_k]
    ranges = rmin + fractions * (rmax - rmin)
    sigma = f["lidar_noise_std"][rows] * f["lidar_noise_scale"][rows]
    noisy = np.flatnonzero(sigma > 0)
    if noisy.size:  # one draw over the noisy robots' rays in row order: the stream one draw per robot gives
        counts = beams[noisy]
        at = np.repeat(spans[noisy, 0] - np.cumsum(counts) + counts, counts) + np.arange(int(counts.sum()))
        ranges[at] += np.repeat(sigma[noisy], counts) * rng.standard_normal(at.size)
    ranges = np.where((uids >= 0) & (ranges >= rmin) & (ranges <= rmax), ranges, np.inf)
    return [LidarScan(table.names[i], stamp, c.angle_min, c.angle_increment, c.range_min, c.range_max,
                      ranges[a:b], uids[a:b])
            for (a, b), i, c in zip(spans.tolist(), rows.tolist(), cfgs, strict=True)]
