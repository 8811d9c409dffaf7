"""Synthetic 2D worlds for the slam tests: line segments, a numpy ray caster and a noisy drive.

Deliberately independent of sim.World, so the SLAM parts are tested against exact geometry.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from planning.grid import OccupancyGrid
from sim.types import LidarScan, Pose2D


def box(cx: float, cy: float, w: float, h: float) -> list[tuple[float, float, float, float]]:
    x0, x1, y0, y1 = cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2
    return [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]


def room(width: float = 20.0, height: float = 14.0) -> np.ndarray:
    """A walled room with box obstacles and pillars (asymmetric, so scans are unambiguous)."""
    segs = box(width / 2, height / 2, width, height)
    segs += box(5.0, 7.0, 2.0, 4.0) + box(10.0, 7.0, 1.0, 1.0) + box(15.0, 7.0, 2.0, 3.0)
    segs += box(3.0, 12.0, 0.6, 0.6) + box(17.0, 2.0, 0.8, 0.5) + box(9.0, 1.5, 3.0, 0.4)
    segs += box(12.5, 11.0, 0.4, 2.5) + box(2.0, 3.0, 0.5, 1.2)
    return np.array(segs, dtype=np.float64)


def raycast(segments: np.ndarray, pose: Pose2D, beams: int = 360, max_range: float = 10.0,
            noise: float = 0.0, rng: np.random.Generator | None = None, stamp: float = 0.0) -> LidarScan:
    """Exact ray-segment intersection for every beam, REP-117 +inf for no return."""
    ang = -math.pi + 2 * math.pi / beams * np.arange(beams)
    d = np.column_stack([np.cos(ang + pose.yaw), np.sin(ang + pose.yaw)])  # (b, 2)
    o = np.array([pose.x, pose.y])
    a, e = segments[:, :2], segments[:, 2:] - segments[:, :2]  # (s, 2)
    denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]  # (b, s)
    ao = a[None, :, :] - o
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ao[..., 0] * e[None, :, 1] - ao[..., 1] * e[None, :, 0]) / denom
        u = (ao[..., 0] * d[:, None, 1] - ao[..., 1] * d[:, None, 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
    r = np.where(hit, t, np.inf).min(axis=1)
    if noise > 0 and rng is not None:
        r = r + rng.normal(0.0, noise, r.shape)
    r[(r > max_range) | (r < 0.1)] = np.inf
    return LidarScan("synth", stamp, -math.pi, 2 * math.pi / beams, 0.1, max_range, r)


def ground_truth_grid(segments: np.ndarray, resolution: float, bounds: tuple[float, float, float, float]
                      ) -> OccupancyGrid:
    """Occupied where a segment passes through the cell, free elsewhere."""
    x0, y0, x1, y1 = bounds
    w, h = round((x1 - x0) / resolution), round((y1 - y0) / resolution)
    data = np.zeros((h, w), dtype=np.int8)
    for sx, sy, ex, ey in segments:
        n = int(math.hypot(ex - sx, ey - sy) / resolution * 4) + 2
        t = np.linspace(0, 1, n)
        cols = np.floor((sx + t * (ex - sx) - x0) / resolution).astype(int)
        rows = np.floor((sy + t * (ey - sy) - y0) / resolution).astype(int)
        ok = (cols >= 0) & (cols < w) & (rows >= 0) & (rows < h)
        data[rows[ok], cols[ok]] = 100
    return OccupancyGrid(data, resolution, (x0, y0))


def polygon_path(pts: list[tuple[float, float]], n: int, step: float, smooth: int) -> list[Pose2D]:
    """`n` poses `step` m apart around the closed polygon `pts` (repeating), the heading smoothed over `smooth`
    poses so corners turn gradually, like a real robot."""
    poly = np.array([*pts, pts[0]], dtype=np.float64)
    seg = np.diff(poly, axis=0)
    lens = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.concatenate([[0.0], np.cumsum(lens)])
    s = (np.arange(n) * step) % cum[-1]
    i = np.searchsorted(cum, s, side="right") - 1
    xy = poly[i] + ((s - cum[i]) / lens[i])[:, None] * seg[i]
    yaw = np.unwrap(np.arctan2(seg[i, 1], seg[i, 0]))
    yaw = np.convolve(np.pad(yaw, (smooth // 2, smooth // 2), mode="edge"), np.ones(smooth) / smooth, mode="valid")
    return [Pose2D(float(x), float(y), math.atan2(math.sin(t), math.cos(t))) for (x, y), t in zip(xy, yaw, strict=True)]


def loop_path(n: int, step: float = 0.1) -> list[Pose2D]:
    """A rounded rectangle loop around the room's obstacles, `n` poses `step` m apart (repeats)."""
    return polygon_path([(3.5, 2.5), (17.0, 2.5 + 0.5), (18.0, 11.5), (8.0, 12.2), (3.5, 10.0)], n, step, smooth=9)


def wheel_odometry(truth: list[Pose2D], rng: np.random.Generator, slip: float = 0.02, bias: float = 0.01
                   ) -> list[Pose2D]:
    """Integrate true increments with multiplicative slip noise and a heading bias, like wheel encoders."""
    out = [truth[0]]
    for a, b in itertools.pairwise(truth):
        c, s = math.cos(a.yaw), math.sin(a.yaw)
        dx, dy = b.x - a.x, b.y - a.y
        fx, fy = c * dx + s * dy, -s * dx + c * dy
        dth = math.atan2(math.sin(b.yaw - a.yaw), math.cos(b.yaw - a.yaw))
        fx *= 1 + rng.normal(0, slip)
        dth = dth * (1 + rng.normal(0, slip)) + bias * abs(fx)
        p = out[-1]
        c2, s2 = math.cos(p.yaw), math.sin(p.yaw)
        out.append(Pose2D(p.x + c2 * fx - s2 * fy, p.y + s2 * fx + c2 * fy,
                          math.atan2(math.sin(p.yaw + dth), math.cos(p.yaw + dth))))
    return out
