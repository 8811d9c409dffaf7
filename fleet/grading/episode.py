"""One graded run as the world sees it: record the robot's trajectory and decide when and how the run ends.

`on_tick` runs on the sim thread after every control tick (a FleetService tick listener); collisions come
from the service's event bus, edge-triggered per contact episode at physics rate, so a contact shorter than a
control period is still counted. Agent faults come the same way (the bridge's `agent_hung` /
`agent_left` events). `finish` may be called from any thread (the runner, on an agent crash); the first
call wins.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from fleet.grading.types import Outcome
from fleet.types import Event, FleetSnapshot
from sim.types import Pose2D

# Events of the Zenoh bridge about the agent that holds the robot: it stopped answering lock-step ticks, or
# its session ended (the process exited or lost the link) before the run did.
AGENT_EVENTS = {"agent_hung": Outcome.AGENT_HUNG, "agent_left": Outcome.AGENT_CRASHED}

if TYPE_CHECKING:
    from fleet.service import FleetService


class Episode:
    def __init__(self, svc: FleetService, robot: str, goal: Pose2D, *, success_radius: float, time_limit: float,
                 collision_rule: str) -> None:
        self.svc, self.robot, self.goal = svc, robot, goal
        self.success_radius, self.time_limit, self.collision_rule = success_radius, time_limit, collision_rule
        self.t0 = 0.0
        self.rows: list[tuple[float, float, float, float, float, float]] = []
        self.collision_times: list[float] = []
        self.collision_messages: list[str] = []
        self.t_goal: float | None = None
        self.outcome: Outcome | None = None
        self.reason = ""
        self.done = threading.Event()
        self._lock = threading.Lock()
        self._unsubscribe: Callable[[], None] | None = None
        # Whether the contestant still drives the robot (e.g. is in lock-step); None: nothing to check.
        self.controlled: Callable[[], bool] | None = None

    def start(self) -> None:
        """Control begins now (time origin); the first row is the current pose. Call on the sim thread."""
        self.t0 = self.svc.world.time
        self._record(self.svc.snapshot)
        self._unsubscribe = self.svc.events.subscribe(self._on_event, kinds=("collision", *AGENT_EVENTS))
        self.svc.tick_listeners.append(self.on_tick)

    def close(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
        if self.on_tick in self.svc.tick_listeners:
            self.svc.tick_listeners.remove(self.on_tick)

    def finish(self, outcome: Outcome, reason: str) -> bool:
        with self._lock:
            if self.outcome is not None:
                return False
            self.outcome, self.reason = outcome, reason
        self.done.set()
        return True

    @property
    def elapsed(self) -> float:
        return self.rows[-1][0] if self.rows else 0.0

    def trajectory(self) -> np.ndarray:
        return np.array(self.rows, dtype=float).reshape(-1, 6)

    # ---- sim thread ---------------------------------------------------------------------------------------

    def _on_event(self, ev: Event) -> None:
        if self.robot not in ev.robots or self.done.is_set():
            return
        if ev.kind == "collision":
            self.collision_times.append(ev.stamp - self.t0)
            self.collision_messages.append(ev.message)
        else:  # the Zenoh bridge lost the robot's controlling agent
            self.finish(AGENT_EVENTS[ev.kind], ev.message)

    def on_tick(self, snap: FleetSnapshot) -> None:
        if self.done.is_set():
            return
        t, x, y = self._record(snap)
        dist = math.hypot(self.goal.x - x, self.goal.y - y)
        if self.controlled is not None and not self.controlled():
            self.finish(Outcome.AGENT_CRASHED, "the agent stopped driving the robot (left lock-step) at "
                                               f"t={t:.2f} s, before the run ended")
        elif self.collision_times and self.collision_rule == "end":
            self.finish(Outcome.COLLISION, f"collision at t={self.collision_times[0]:.2f} s: "
                                           f"{self.collision_messages[0]}")
        elif dist <= self.success_radius:
            self.t_goal = t
            self.finish(Outcome.SUCCEEDED, f"goal reached at t={t:.2f} s ({dist:.2f} m from it)")
        elif t >= self.time_limit - 1e-9:
            closest = min(math.hypot(self.goal.x - r[1], self.goal.y - r[2]) for r in self.rows)
            self.finish(Outcome.TIMEOUT, f"goal not reached within the time limit of {self.time_limit:g} s "
                                         f"(closest approach {closest:.2f} m, radius {self.success_radius:g} m)")

    def _record(self, snap: FleetSnapshot) -> tuple[float, float, float]:
        i = snap.index(self.robot)
        x, y, yaw = (float(v) for v in snap.pose[i])
        v, w = (float(u) for u in snap.twist[i])
        t = round(snap.time - self.t0, 9)
        self.rows.append((t, x, y, yaw, v, w))
        return t, x, y
