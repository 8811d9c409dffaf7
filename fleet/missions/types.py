"""Interfaces and result types of the missions package: poses in mission files, what a run measured, what
each assertion concluded, and the outcome of one run."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.service import FleetService
    from planning.grid import OccupancyGrid


class PoseSpec(StrictModel):
    """A pose in the map frame, `{x, y, yaw}` (yaw in radians, default 0)."""

    x: float = Field(allow_inf_nan=False)
    y: float = Field(allow_inf_nan=False)
    yaw: float = Field(0.0, allow_inf_nan=False)

    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


@dataclass
class TaskRecord:
    """A task the mission submitted, under its mission key (service task ids are not stable across runs)."""

    key: str
    robot: str
    type: str
    task_id: str
    params: dict[str, Any]
    state: str = "queued"
    reason: str = ""
    started: float | None = None
    finished: float | None = None
    progress: dict[str, Any] = field(default_factory=dict)


@dataclass
class RunData:
    """Everything a run measured, for assertions, reports and plots. Trajectories are sampled at the control
    rate: `traj[robot]` is (k, 4) rows of (t, x, y, yaw)."""

    time_limit: float
    end_time: float = 0.0
    ended_because: str = ""
    traj: dict[str, np.ndarray] = field(default_factory=dict)
    radius: dict[str, float] = field(default_factory=dict)  # footprint radius per robot, m
    v_max: dict[str, float] = field(default_factory=dict)  # linear speed limit per robot, m/s
    collisions: list[dict[str, Any]] = field(default_factory=list)
    min_static_clearance: dict[str, float] = field(default_factory=dict)  # footprint edge to obstacle, m
    min_robot_gap: float = math.inf  # smallest footprint-to-footprint gap between two robots, m
    tasks: dict[str, TaskRecord] = field(default_factory=dict)
    behaviours: dict[str, dict[str, Any]] = field(default_factory=dict)
    slam: dict[str, dict[str, float]] = field(default_factory=dict)
    event_counts: dict[str, int] = field(default_factory=dict)
    scripted: list[dict[str, Any]] = field(default_factory=list)  # what each scripted event did, and when
    setup_errors: list[str] = field(default_factory=list)
    removed: dict[str, float] = field(default_factory=dict)  # robot → time it was killed
    agents: dict[str, dict[str, Any]] = field(default_factory=dict)
    service: FleetService | None = None  # alive while assertions are evaluated (optimal paths, maps)
    grid: OccupancyGrid | None = None  # the static map at the end of the run (for the plot)
    optimal_length: Callable[[str, Pose2D, Pose2D], float] | None = None


@dataclass(frozen=True)
class AssertionResult:
    """One assertion: what was measured against what was required. `message` carries both numbers."""

    name: str
    type: str
    passed: bool
    measured: float | str | None
    expected: str
    message: str
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        m = self.measured
        return {"name": self.name, "type": self.type, "passed": self.passed,
                "measured": round(m, 6) if isinstance(m, float) and math.isfinite(m) else
                (None if isinstance(m, float) else m),
                "expected": self.expected, "message": self.message, "details": _clean(self.details)}


@dataclass
class RunOutcome:
    """The result of one mission run: the report (deterministic part), wall-clock figures, where it wrote."""

    mission: str
    source: str
    seed: int
    passed: bool
    report: dict[str, Any]
    out_dir: Path
    wall_s: float = 0.0
    error: str = ""

    def summary(self) -> str:
        verdict = "PASS" if self.passed else "FAIL"
        failed = [a["name"] for a in self.report.get("assertions", []) if not a["passed"]]
        extra = f" (failed: {', '.join(failed)})" if failed else ""
        if self.error:
            extra = f" ({self.error})"
        return f"{verdict} {self.mission} seed={self.seed} sim={self.report.get('end_time', 0):.1f}s " \
               f"wall={self.wall_s:.1f}s{extra}"


def _clean(v: Any) -> Any:
    """JSON-safe and stable: floats rounded to 6 places, non-finite as null, arrays as lists."""
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_clean(x) for x in v]
    if isinstance(v, np.ndarray):
        return _clean(v.tolist())
    if isinstance(v, np.generic):
        return _clean(v.item())
    if isinstance(v, float):
        return round(v, 6) if math.isfinite(v) else None
    if isinstance(v, Pose2D):
        return {"x": round(v.x, 6), "y": round(v.y, 6), "yaw": round(v.yaw, 6)}
    return v


clean = _clean
