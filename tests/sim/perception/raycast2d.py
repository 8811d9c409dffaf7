"""Closed-form planar ray casting against circles and rotated rectangles: ground-truth scans for tests."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.types import LidarScan


@dataclass(frozen=True)
class Circle:
    x: float
    y: float
    r: float


@dataclass(frozen=True)
class Rect:
    x: float
    y: float
    sx: float
    sy: float
    yaw: float = 0.0


def _hit_circle(o: np.ndarray, d: np.ndarray, c: Circle) -> np.ndarray:
    oc = o - np.array([c.x, c.y])
    b = d @ oc
    disc = b * b - (oc @ oc - c.r * c.r)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def _hit_rect(o: np.ndarray, d: np.ndarray, rc: Rect) -> np.ndarray:
    c, s = math.cos(rc.yaw), math.sin(rc.yaw)
    rot = np.array([[c, -s], [s, c]])
    lo_o = (o - np.array([rc.x, rc.y])) @ rot  # into the rectangle frame
    lo_d = d @ rot
    half = np.array([rc.sx / 2, rc.sy / 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - lo_o) / lo_d
        t2 = (half - lo_o) / lo_d
    tmin = np.nanmax(np.minimum(t1, t2), axis=1)
    tmax = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((tmax >= tmin) & (tmin > 0), tmin, np.inf)


def scan_from(x: float, y: float, yaw: float, shapes: list[Circle | Rect], beams: int = 360,
              range_max: float = 10.0, noise: float = 0.0, rng: np.random.Generator | None = None
              ) -> LidarScan:
    """A 360° scan from a lidar at (x, y, yaw) in the world, beams from −π like sim.World's."""
    angles = -math.pi + 2 * math.pi / beams * np.arange(beams)
    d = np.column_stack([np.cos(angles + yaw), np.sin(angles + yaw)])
    o = np.array([x, y])
    ranges = np.full(beams, np.inf)
    for sh in shapes:
        ranges = np.minimum(ranges, _hit_circle(o, d, sh) if isinstance(sh, Circle) else _hit_rect(o, d, sh))
    if noise > 0:
        gen = rng if rng is not None else np.random.default_rng(0)
        ranges = ranges + gen.normal(0.0, noise, beams)
    ranges = np.where(ranges <= range_max, ranges, np.inf)
    return LidarScan("r", 0.0, -math.pi, 2 * math.pi / beams, 0.1, range_max, ranges)
