"""Result types of grading: one run's outcome and score breakdown, a challenge's report over several runs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from fleet.grading.rubric import RubricReport

TRAJ_COLUMNS = ("t", "x", "y", "yaw", "v", "w")  # a run's trajectory, one row per control tick


class Outcome(StrEnum):
    """How a run ended. Only SUCCEEDED counts as success; every other outcome carries a reason."""

    SUCCEEDED = "succeeded"
    COLLISION = "collision"  # collision rule `end`: the first contact ends the run
    TIMEOUT = "timeout"  # the sim-time limit passed before the goal was reached
    AGENT_CRASHED = "agent_crashed"  # the contestant's process exited (an exception, a non-zero code, or early)
    AGENT_HUNG = "agent_hung"  # the contestant stopped answering lock-step ticks
    AGENT_DID_NOT_CONNECT = "agent_did_not_connect"
    WALL_TIMEOUT = "wall_timeout"  # the wall-clock budget ran out (a slow but alive agent)
    NAVIGATION_FAILED = "navigation_failed"  # a builtin navigator gave up (planning or recovery failure)


@dataclass(frozen=True)
class RunScore:
    """The BARN score and its breakdown for one run. Times in sim seconds, lengths in metres."""

    success: bool
    score: float  # success × T_opt / clip(T, 2·T_opt, 8·T_opt)
    time: float  # T: start of control to goal reached (or to the end of the run when not reached)
    t_opt: float  # optimal path length / max speed
    optimal_length: float
    path_length: float
    spl: float  # success × L_opt / max(L, L_opt)
    collisions: int  # contact episodes
    first_collision_time: float | None
    min_clearance: float  # footprint to nearest static obstacle (exact, fcl), m
    time_in_danger: float  # s with clearance below the safety distance
    mean_speed: float
    accel_rms: float  # velocity smoothness: RMS of dv/dt, m/s²
    jerk_rms: float  # RMS of d²v/dt², m/s³
    angular_jerk_rms: float  # RMS of d²ω/dt², rad/s³
    curvature_mean: float  # total turning / path length, 1/m
    curvature_max: float  # max |ω|/|v| while moving, 1/m
    final_distance: float  # distance to the goal at the end, m

    def to_dict(self) -> dict[str, Any]:
        return {k: _json_number(v) for k, v in self.__dict__.items()}


@dataclass
class RunResult:
    run: int
    seed: int
    outcome: Outcome
    reason: str
    score: RunScore
    trajectory: np.ndarray  # (k, 6) rows of TRAJ_COLUMNS
    wall_time_s: float = 0.0
    agent_log: str = ""  # the tail of the contestant's stderr, when there is a process

    def to_dict(self) -> dict[str, Any]:
        return {"run": self.run, "seed": self.seed, "outcome": self.outcome.value, "reason": self.reason,
                **self.score.to_dict(), "wall_time_s": round(self.wall_time_s, 3),
                "agent_log": self.agent_log}


@dataclass(frozen=True)
class Stat:
    """Mean, spread (sample standard deviation) and range of one figure over runs."""

    mean: float
    std: float
    min: float
    max: float

    @staticmethod
    def of(values: list[float]) -> Stat:
        v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
        if not v.size:
            return Stat(math.nan, math.nan, math.nan, math.nan)
        std = float(v.std(ddof=1)) if v.size > 1 else 0.0
        return Stat(float(v.mean()), std, float(v.min()), float(v.max()))

    def to_dict(self) -> dict[str, float | None]:
        return {k: _json_number(v) for k, v in self.__dict__.items()}


@dataclass
class ChallengeReport:
    challenge: str
    contestant: str  # the agent command, or builtin:<name>
    config: dict[str, Any]  # the challenge as run (resolved start and goal included)
    runs: list[RunResult]
    summary: dict[str, Any]  # success_rate, score/time/... Stats (see score.summarize)
    rubric: RubricReport
    files: dict[str, Path] = field(default_factory=dict)  # json, md, html, png, csv → written paths

    @property
    def success_rate(self) -> float:
        return float(self.summary["success_rate"])

    @property
    def mean_score(self) -> float:
        return float(self.summary["score"]["mean"])

    def to_dict(self) -> dict[str, Any]:
        return {"challenge": self.challenge, "contestant": self.contestant, "config": self.config,
                "summary": self.summary, "runs": [r.to_dict() for r in self.runs], "rubric": self.rubric.to_dict(),
                "files": {k: str(v) for k, v in self.files.items()}}


def _json_number(v: Any) -> Any:
    """JSON has no NaN/inf: write them as null (the Markdown/HTML pages print them as '—')."""
    if isinstance(v, float | np.floating):
        f = float(v)
        return round(f, 6) if math.isfinite(f) else None
    if isinstance(v, np.bool_):
        return bool(v)
    return v
