"""Result and status types of the navigation layer: controllers, the reactive layer, the navigator,
waypoint missions and coverage. (planning/types.py holds the maps-and-planners types.)

Long actions end as `succeeded | failed(reason) | canceled` (ARCHITECTURE.md); while they run they report
progress in sim time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from sim.types import Pose2D


class NavState(StrEnum):
    IDLE = "idle"  # no goal yet
    PLANNING = "planning"  # asking the global planner (one tick)
    TRACKING = "tracking"  # following the path with the controller
    RECOVERING = "recovering"  # running a recovery behaviour (clear costmap, back up, rotate)
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELED = "canceled"

    @property
    def done(self) -> bool:
        return self in (NavState.SUCCEEDED, NavState.FAILED, NavState.CANCELED)


@dataclass(frozen=True, slots=True)
class NavStatus:
    """What a navigation action is doing and how far it has to go (distances in m, times in sim s)."""

    state: NavState
    reason: str = ""  # why it failed, or what triggered the current replan/recovery
    distance_remaining: float = math.nan  # along the current path
    eta_s: float = math.nan  # distance_remaining over the recently achieved speed (or the path's speed)
    elapsed_s: float = 0.0  # since the goal was set
    replans: int = 0
    recoveries: int = 0
    path_length: float = math.nan  # of the path being tracked (latest plan, smoothed; a route included)
    goal: Pose2D | None = None

    def to_dict(self) -> dict[str, object]:
        return {"state": self.state.value, "reason": self.reason,
                "distance_remaining": self.distance_remaining, "eta_s": self.eta_s,
                "elapsed_s": self.elapsed_s, "replans": self.replans, "recoveries": self.recoveries,
                "path_length": self.path_length,
                "goal": None if self.goal is None else {"x": self.goal.x, "y": self.goal.y, "yaw": self.goal.yaw}}


@dataclass(frozen=True, slots=True)
class ControlOutput:
    """One controller step: the command, where the robot is along the reference, and solver figures."""

    v: float
    w: float
    progress: float  # arc length of the robot's projection on the reference, m
    cross_track: float  # signed lateral error, m (positive: robot left of the path)
    solve_time_s: float = 0.0  # wall clock spent in the optimiser (0 for geometric controllers)
    converged: bool = True  # False when an optimiser returned without meeting its tolerance
    predicted: np.ndarray | None = None  # (N+1, 3) predicted states x, y, yaw (MPC only)


class SafetyState(StrEnum):
    CLEAR = "clear"
    SLOWING = "slowing"
    STOPPED = "stopped"


@dataclass(frozen=True, slots=True)
class SafetyResult:
    """The reactive layer's verdict on a command."""

    v: float
    w: float
    state: SafetyState
    distance_to_collision: float  # along the commanded motion, m (inf when nothing is in the way)
    blocked: bool = False  # stopped for longer than the blocked timeout: the navigator should replan
    clamped: bool = False  # True when (v, w) differ from the request


@dataclass(frozen=True, slots=True)
class Waypoint:
    pose: Pose2D
    dwell_s: float = 0.0  # wait this long (sim time) after arriving
    use_yaw: bool = False  # also align with pose.yaw on arrival


@dataclass(frozen=True, slots=True)
class WaypointVisit:
    index: int  # position in the waypoint list
    round: int  # 0-based round (patrol/loop)
    arrived_at: float  # sim time
    pose: Pose2D  # where the robot actually was


@dataclass(frozen=True, slots=True)
class WaypointStatus:
    state: NavState
    reason: str = ""
    current_index: int = 0
    current_round: int = 0
    visits: tuple[WaypointVisit, ...] = ()
    dwelling: bool = False
    leg: NavStatus | None = None  # the navigator's status on the current leg


@dataclass(frozen=True, slots=True)
class CoveragePlan:
    """A coverage path over a polygon and how well it covers it.

    coverage_pct: area swept by the tool (a disc of the tool width moved along `path`) inside the region,
    over the region's area. overlap_pct: area swept more than once, estimated as (path length × tool width
    − swept area) over the swept area.
    """

    path: np.ndarray  # (N, 2) map-frame points to drive through, in order
    pattern: str  # "boustrophedon" | "spiral"
    tool_width: float
    overlap: float  # requested fraction of the tool width shared by neighbouring passes
    passes: int  # straight swaths (boustrophedon) or rings (spiral)
    cells: int  # boustrophedon cells (1 for spiral)
    length: float  # m
    area: float  # m², of the region
    coverage_pct: float
    overlap_pct: float
    swaths: tuple[np.ndarray, ...] = field(default=())  # each (2, 2) start/end of one straight pass
