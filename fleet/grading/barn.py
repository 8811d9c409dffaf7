"""The BARN benchmark's rules and metric, exactly as the_barn_challenge's run.py computes them.

- start (−2.25, 3, yaw 1.57), goal (−2.25, 13) (run.py: INIT_POSITION and INIT + GOAL_POSITION (0, 10));
- optimal path: the world's `path_N.npy` in world coordinates, x = i·0.15 − 4.575, y = j·0.15 + 5.075
  (run.py's path_coord_to_gazebo_coord), with the start prepended and the goal appended; T_opt = its
  length / 2.0 m/s (the Jackal's top speed);
- T: from the moment the robot is 0.1 m from its start to the moment it is within 1 m of the goal;
- success: within 1 m of the goal, no collision, T < 100 s;
- metric = success × T_opt / clip(T, 2·T_opt, 8·T_opt).

This is BARN's score; the project's challenge score (fleet.grading.score) is its own variant.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

BARN_START = Pose2D(-2.25, 3.0, 1.57)
BARN_GOAL = Pose2D(-2.25, 13.0, 0.0)
SUCCESS_RADIUS = 1.0  # m
START_RADIUS = 0.1  # m: the clock starts when the robot is this far from its start
TIME_LIMIT = 100.0  # s
V_OPT = 2.0  # m/s
CELL, X_SHIFT, Y_SHIFT = 0.15, -4.575, 5.075  # path file (i, j) → world


@dataclass(frozen=True)
class BarnPair:
    id: int
    world: Path
    path: Path


def path_to_world(ij: np.ndarray) -> np.ndarray:
    """Path-file cells (n, 2) → world coordinates (n, 2)."""
    ij = np.asarray(ij, dtype=float).reshape(-1, 2)
    return np.column_stack([ij[:, 0] * CELL + X_SHIFT, ij[:, 1] * CELL + Y_SHIFT])


def optimal_length(path_file: Path | np.ndarray, start: Pose2D = BARN_START, goal: Pose2D = BARN_GOAL) -> float:
    """Length of the path file in world coordinates plus the start and goal segments, m."""
    ij = np.load(path_file) if isinstance(path_file, Path) else path_file
    pts = np.vstack([[start.x, start.y], path_to_world(ij), [goal.x, goal.y]])
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def barn_metric(success: bool, t: float, t_opt: float) -> float:
    """success × T_opt / clip(T, 2·T_opt, 8·T_opt)."""
    return float(t_opt / min(max(t, 2.0 * t_opt), 8.0 * t_opt)) if success else 0.0


def find_pairs(worlds_dir: Path, ids: list[int] | None = None) -> list[BarnPair]:
    """The (world_N.world, path_N.npy) pairs in `worlds_dir`, all or the given ids, sorted by id."""
    if not worlds_dir.is_dir():
        raise FleetError(ErrorCode.NOT_FOUND, f"BARN worlds directory {worlds_dir} does not exist",
                         "pass --worlds-dir with world_N.world and path_N.npy files")
    found = {int(m.group(1)): p for p in worlds_dir.iterdir() if (m := re.fullmatch(r"world_(\d+)\.world", p.name))}
    wanted = sorted(found) if ids is None else ids
    missing = [i for i in wanted if i not in found or not (worlds_dir / f"path_{i}.npy").is_file()]
    if missing:
        have = sorted(i for i in found if (worlds_dir / f"path_{i}.npy").is_file())
        raise FleetError(ErrorCode.NOT_FOUND, f"no world_N.world + path_N.npy pair for id(s) {missing} in "
                         f"{worlds_dir}", f"available ids: {have[:60]}{' …' if len(have) > 60 else ''}")
    if not wanted:
        raise FleetError(ErrorCode.NOT_FOUND, f"no world_N.world files in {worlds_dir}",
                         "the directory must hold BARN worlds (world_N.world) and path files (path_N.npy)")
    return [BarnPair(i, found[i], worlds_dir / f"path_{i}.npy") for i in wanted]


class BarnClock:
    """BARN's run loop as a state machine fed with the ground-truth pose each tick."""

    def __init__(self, start: Pose2D = BARN_START, goal: Pose2D = BARN_GOAL) -> None:
        self.start, self.goal = start, goal
        self.t_start: float | None = None
        self.t_end: float | None = None
        self.collided = False
        self.outcome = ""  # "", "succeeded", "collided", "timeout"

    def update(self, now: float, pose: Pose2D, in_collision: bool) -> str:
        if self.outcome:
            return self.outcome
        if self.t_start is None:
            if math.hypot(pose.x - self.start.x, pose.y - self.start.y) < START_RADIUS:
                if in_collision:
                    self.collided = True
                    self.outcome, self.t_start, self.t_end = "collided", now, now
                return self.outcome
            self.t_start = now
        self.collided |= in_collision
        if self.collided:
            self.outcome, self.t_end = "collided", now
        elif math.hypot(pose.x - self.goal.x, pose.y - self.goal.y) <= SUCCESS_RADIUS:
            self.outcome, self.t_end = "succeeded", now
        elif now - self.t_start >= TIME_LIMIT:
            self.outcome, self.t_end = "timeout", now
        return self.outcome

    @property
    def elapsed(self) -> float:
        if self.t_start is None:
            return 0.0
        return (self.t_end if self.t_end is not None else self.t_start) - self.t_start
