"""Interfaces and result types of the planning package.

Cost values follow nav2's costmap_2d convention (uint8): 0 free, 1..252 decaying inflation cost,
253 inscribed (the robot centre here means a collision), 254 lethal (an obstacle cell), 255 unknown.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from sim.types import LidarScan, Pose2D

FREE: int = 0
INSCRIBED: int = 253
LETHAL: int = 254
UNKNOWN: int = 255

Polygon = Sequence[tuple[float, float]]  # (x, y) vertices in metres, map frame, either winding


@runtime_checkable
class Costmap(Protocol):
    """What planners, controllers and the navigator need from a costmap (planning.costmap.LayeredCostmap).

    Points are map-frame metres. Points outside the map are not free, cost LETHAL and have clearance 0.
    """

    @property
    def resolution(self) -> float:
        """Cell edge, m."""
        ...

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the map, m."""
        ...

    @property
    def robot_radius(self) -> float:
        """The inscribed radius the costmap was inflated with, m."""
        ...

    @property
    def costs(self) -> np.ndarray:
        """Combined cost, uint8 (height, width); row 0 is the bottom row (y = bounds ymin)."""
        ...

    @property
    def free_mask(self) -> np.ndarray:
        """bool (height, width): cells where the robot centre may be (what is_free looks up)."""
        ...

    @property
    def version(self) -> int:
        """Changes whenever any layer changes and is never reused by another costmap: a cache key."""
        ...

    def is_free(self, x: float, y: float) -> bool:
        """True when the robot centred at (x, y) does not touch a lethal or keep-out cell."""
        ...

    def cost_at(self, x: float, y: float) -> int: ...

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest lethal cell (static, scanned or keep-out), m."""
        ...

    def is_free_many(self, xy: np.ndarray) -> np.ndarray:
        """Vectorised is_free over (n, 2) points → bool (n,)."""
        ...

    def clearance_many(self, xy: np.ndarray) -> np.ndarray:
        """Vectorised clearance over (n, 2) points → float (n,)."""
        ...

    def segment_free(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        """True when every cell the straight segment a→b crosses is free for the robot centre."""
        ...

    def update_from_scan(self, scan: LidarScan, pose: Pose2D) -> None:
        """Mark beam endpoints as obstacles and clear the cells the beams passed through."""
        ...

    def clear_dynamic(self, around: tuple[float, float, float] | None = None) -> None:
        """Forget what the scans added (recovery behaviour 'clear costmap'); with `around` = (x, y, r) only
        within r of (x, y) (nav2's ClearCostmapAroundRobot), so a map built from the scans survives."""
        ...

    def add_keepout(self, polygon: Polygon) -> None:
        """Forbid a polygonal zone (treated as lethal, so it is inflated too)."""
        ...


@dataclass(frozen=True, slots=True)
class PlanResult:
    """A collision-free geometric path from start to goal."""

    path: np.ndarray  # (N, 2) map-frame points, N >= 2, first = start, last = goal
    length: float  # m, polyline length of `path`
    planning_time_s: float  # wall-clock seconds spent planning (incl. simplification)
    planner: str  # registry name of the planner that produced it
    start: Pose2D
    goal: Pose2D
    expansions: int = 0  # grid nodes expanded (grid planners; 0 for OMPL), for diagnostics
    info: dict[str, float] = field(default_factory=dict)  # planner-specific figures (e.g. raw length)

    def yaws(self) -> np.ndarray:
        """Heading of each path point: direction of the next segment; the last takes the goal yaw."""
        d = np.diff(self.path, axis=0)
        return np.append(np.arctan2(d[:, 1], d[:, 0]), self.goal.yaw)


@runtime_checkable
class GlobalPlanner(Protocol):
    """A global planner. Raises FleetError(PLANNING_FAILED, reason, hint) when it cannot plan."""

    name: str

    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap) -> PlanResult: ...


@dataclass(frozen=True, slots=True)
class Trajectory:
    """Timed samples of a path for a unicycle: arrays of equal length, t strictly increasing from 0."""

    t: np.ndarray  # s
    x: np.ndarray  # m
    y: np.ndarray  # m
    yaw: np.ndarray  # rad
    v: np.ndarray  # m/s, along the path
    w: np.ndarray  # rad/s
    max_v: float = math.inf  # the limits it was parameterised with
    max_a: float = math.inf

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    @property
    def length(self) -> float:
        return float(np.hypot(np.diff(self.x), np.diff(self.y)).sum())

    def __len__(self) -> int:
        return int(self.t.size)

    def xy(self) -> np.ndarray:
        return np.column_stack([self.x, self.y])

    def sample(self, t: float) -> tuple[float, float, float, float, float]:
        """(x, y, yaw, v, w) at time t by linear interpolation (yaw unwrapped first); clamped to the ends."""
        tt = min(max(t, 0.0), self.duration)
        yaw = float(np.interp(tt, self.t, np.unwrap(self.yaw)))
        yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        return (float(np.interp(tt, self.t, self.x)), float(np.interp(tt, self.t, self.y)), yaw,
                float(np.interp(tt, self.t, self.v)), float(np.interp(tt, self.t, self.w)))
