"""Recovery behaviours the navigator runs when it is stuck: clear the costmap, back up, spin.

Each attempt escalates (nav2's recovery tree, flattened): attempt 1 clears the scanned obstacles, attempt
2 also backs up, attempt 3+ also spins. Motions are open-loop twists ended by odometry (distance or angle
achieved) or by a sim-time limit; the reactive layer still filters them, so a back-up never hits a wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planning.types import Costmap
from sim.config import StrictModel
from sim.types import Pose2D


class RecoveryConfig(StrictModel):
    backup_distance: float = 0.3  # m
    backup_speed: float = 0.15  # m/s
    spin_angle: float = math.pi / 2  # rad
    spin_speed: float = 1.0  # rad/s
    step_timeout_s: float = 5.0  # give up on one motion after this much sim time


@dataclass(slots=True)
class _Motion:
    kind: str  # "backup" | "spin"
    start: Pose2D
    started_at: float
    turned: float = 0.0
    last_yaw: float = 0.0


class Recovery:
    """One recovery attempt at a time: `begin(attempt, ...)`, then `step(...)` until it returns None."""

    def __init__(self, *, backup_distance: float = 0.3, backup_speed: float = 0.15,
                 spin_angle: float = math.pi / 2, spin_speed: float = 1.0, step_timeout_s: float = 5.0) -> None:
        self.backup_distance, self.backup_speed = backup_distance, backup_speed
        self.spin_angle, self.spin_speed, self.timeout = spin_angle, spin_speed, step_timeout_s
        self._queue: list[str] = []
        self._motion: _Motion | None = None

    @property
    def active(self) -> bool:
        return bool(self._queue) or self._motion is not None

    def begin(self, attempt: int, costmap: Costmap,
              around: tuple[float, float, float] | None = None) -> list[str]:
        """Start attempt `attempt` (1-based); returns the behaviours it will run. With `around` (x, y, r) the
        costmap is cleared only there: a map built from the scans is all a sensors-only robot knows."""
        costmap.clear_dynamic(around)
        plan = ["clear_costmap"] + (["backup"] if attempt >= 2 else []) + (["spin"] if attempt >= 3 else [])
        self._queue = plan[1:]
        self._motion = None
        return plan

    def cancel(self) -> None:
        self._queue, self._motion = [], None

    def step(self, now: float, pose: Pose2D) -> tuple[float, float] | None:
        """The twist for this tick, or None when the attempt is over."""
        while True:
            if self._motion is None:
                if not self._queue:
                    return None
                self._motion = _Motion(self._queue.pop(0), pose, now, last_yaw=pose.yaw)
            m = self._motion
            if m.kind == "backup" and pose.distance_to(m.start) < self.backup_distance and not self._late(m, now):
                return (-self.backup_speed, 0.0)
            if m.kind == "spin":
                m.turned += abs(math.remainder(pose.yaw - m.last_yaw, 2 * math.pi))
                m.last_yaw = pose.yaw
                if m.turned < self.spin_angle and not self._late(m, now):
                    return (0.0, self.spin_speed)
            self._motion = None  # this motion is done: next one, same tick

    def _late(self, m: _Motion, now: float) -> bool:
        return now - m.started_at > self.timeout
