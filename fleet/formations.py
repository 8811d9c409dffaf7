"""Formations: slot geometry (line, column, grid, circle, wedge), collision-free placement, slot assignment.

Offsets are in the formation frame (x forward, y left, REP-103) and centred on the formation's centroid,
so a formation at pose (x, y, yaw) puts robot k at (x, y) + R(yaw)·offset_k. Placement checks every slot
against the static map (free space for the robot's footprint) and against robots already in the world;
`random` samples slots by rejection with a minimum separation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

SHAPES = ("line", "column", "grid", "circle", "wedge")
FORMATIONS = (*SHAPES, "random")
MAX_ROBOTS = 1000
FreeFn = Callable[[np.ndarray], np.ndarray]  # (n, 2) points → (n,) bool: a robot centred there is clear


@dataclass(frozen=True)
class Formation:
    """A formation a group of robots was put in: who holds which slot (offsets in the formation frame)."""

    kind: str
    spacing: float
    yaw: float
    robots: tuple[str, ...]
    offsets: np.ndarray  # (n, 2), row k is robots[k]'s slot

    def offsets_of(self, robots: list[str]) -> np.ndarray:
        """The slots of a subset, re-centred on their own centroid."""
        rows = self.offsets[[self.robots.index(r) for r in robots]]
        return np.asarray(rows - rows.mean(axis=0))


def check_kind(kind: str, allowed: tuple[str, ...] = FORMATIONS) -> str:
    if kind not in allowed:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown formation '{kind}'",
                         f"known formations: {', '.join(allowed)}")
    return kind


def formation_offsets(kind: str, count: int, spacing: float) -> np.ndarray:
    """(count, 2) slot offsets with neighbouring slots `spacing` apart, centroid at the origin."""
    check_kind(kind, SHAPES)
    if not 1 <= count <= MAX_ROBOTS:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"count must be in [1, {MAX_ROBOTS}], got {count}")
    if not (math.isfinite(spacing) and spacing > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"spacing must be > 0 m, got {spacing}")
    k = np.arange(count, dtype=float)
    if kind == "line":  # abreast, left to right
        pts = np.column_stack([np.zeros(count), -k * spacing])
    elif kind == "column":  # single file, front to back
        pts = np.column_stack([-k * spacing, np.zeros(count)])
    elif kind == "grid":  # rows of ceil(sqrt(n)), front row first
        cols = math.ceil(math.sqrt(count))
        pts = np.column_stack([-(k // cols) * spacing, -(k % cols) * spacing])
    elif kind == "circle":  # neighbours one chord `spacing` apart: R = s / (2 sin(π/n))
        r = 0.0 if count == 1 else spacing / (2 * math.sin(math.pi / count))
        a = 2 * math.pi * k / count
        pts = np.column_stack([r * np.cos(a), r * np.sin(a)])
    else:  # wedge: apex in front, arms at ±45° behind it, alternating left/right
        rank = np.ceil(k / 2)
        side = np.where(k % 2 == 1, 1.0, -1.0)
        pts = np.column_stack([-rank * spacing * math.sqrt(0.5), side * rank * spacing * math.sqrt(0.5)])
    return np.asarray(pts - pts.mean(axis=0))


def to_world(offsets: np.ndarray, centre: Pose2D) -> np.ndarray:
    c, s = math.cos(centre.yaw), math.sin(centre.yaw)
    return np.column_stack([centre.x + c * offsets[:, 0] - s * offsets[:, 1],
                            centre.y + s * offsets[:, 0] + c * offsets[:, 1]])


def to_frame(xy: np.ndarray, centre: Pose2D) -> np.ndarray:
    """World points → formation-frame offsets about `centre` (the inverse of to_world)."""
    c, s = math.cos(centre.yaw), math.sin(centre.yaw)
    d = xy - np.array([centre.x, centre.y])
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])


def random_slots(count: int, centre: Pose2D, radius: float, min_separation: float, free: FreeFn,
                 rng: np.random.Generator, existing: np.ndarray, max_attempts: int = 200,
                 bounds: tuple[float, float, float, float] | None = None) -> np.ndarray:
    """Rejection sampling in the disc of `radius` about `centre` (and within `bounds`): free space,
    `min_separation` from each other and from `existing` robots. Candidates come in batches (one array test
    per batch)."""
    chosen: list[np.ndarray] = []
    others = existing.reshape(-1, 2)
    for _ in range(max_attempts):
        if len(chosen) == count:
            break
        batch = 4 * (count - len(chosen)) + 8
        r = radius * np.sqrt(rng.random(batch))  # uniform over the disc's area
        a = rng.uniform(0, 2 * math.pi, batch)
        cand = np.column_stack([centre.x + r * np.cos(a), centre.y + r * np.sin(a)])
        ok = free(cand)
        if bounds is not None:
            ok &= (cand[:, 0] >= bounds[0]) & (cand[:, 1] >= bounds[1]) & (cand[:, 0] <= bounds[2]) & \
                (cand[:, 1] <= bounds[3])
        for p in cand[ok]:
            taken = np.vstack([others, *chosen]) if chosen else others
            if not len(taken) or np.hypot(*(taken - p).T).min() >= min_separation:
                chosen.append(p)
                if len(chosen) == count:
                    break
    if len(chosen) < count:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"could place only {len(chosen)} of {count} robots at random "
                         f"within {radius:.1f} m of ({centre.x:.1f}, {centre.y:.1f}) with {min_separation:.2f} m "
                         "separation", "enlarge the radius, move the centre into open space or spawn fewer")
    return np.array(chosen)


def check_slots(xy: np.ndarray, free: FreeFn, min_separation: float, existing: dict[str, tuple[float, float]]) -> None:
    """Every slot must be in free space and clear of robots already in the world; say which are not."""
    blocked = np.flatnonzero(~free(xy))
    if len(blocked):
        where = ", ".join(f"#{k} ({xy[k, 0]:.2f}, {xy[k, 1]:.2f})" for k in blocked[:5])
        raise FleetError(ErrorCode.COLLISION, f"{len(blocked)} formation slot(s) are not in free space: {where}",
                         "move the centre into open space, reduce the spacing, or use formation 'random'")
    if existing:
        names = list(existing)
        pts = np.array([existing[n] for n in names])
        d = np.hypot(*(xy[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
        clash = sorted({names[j] for j in np.flatnonzero((d < min_separation).any(axis=0))})
        if clash:
            raise FleetError(ErrorCode.COLLISION, f"formation slots overlap robots {', '.join(clash[:10])}",
                             "choose another centre, or remove or move those robots first")


def assign_slots(current: np.ndarray, slots: np.ndarray) -> np.ndarray:
    """perm with robot k → slots[perm[k]], minimising the total squared travel (Hungarian algorithm). The
    squared-distance optimum has no crossing straight-line paths, so robots do not cut through each other."""
    cost = ((current[:, None, :] - slots[None, :, :]) ** 2).sum(axis=2)
    rows, cols = linear_sum_assignment(cost)
    perm = np.empty(len(current), dtype=np.int64)
    perm[rows] = cols
    return perm


def heading_mean(yaw: np.ndarray) -> float:
    return float(math.atan2(np.sin(yaw).mean(), np.cos(yaw).mean())) if len(yaw) else 0.0
