"""follow_robot: keep `distance` behind another robot, re-planning as it moves.

The follower's goal is the point `distance` behind the target along the target's heading (or, when that
point is not free, the point `distance` from the target on the line towards the follower). The navigator is
re-aimed whenever that point has moved more than `regoal_distance` since the last goal; once there, the
follower holds still. It ends succeeded after `duration` s (if given), canceled on request, or failed when
the target disappears or the goal stays unreachable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from fleet.tasks.base import Command, TaskContext, register_task
from fleet.tasks.basic import NavTask
from planning.nav_types import NavState
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

MAX_FAILURES = 5  # consecutive failed legs before the task gives up
RETRY_S = 1.0  # after a failed leg, try again this much later (the target may have moved)


@register_task
@dataclass(eq=False)
class FollowRobotTask(NavTask):
    """Follow `target` at `distance` m (default 1.0) for `duration` s (default: until canceled);
    `regoal_distance` (0.3 m) is how far the follow point moves before the follower re-plans."""

    type_name = "follow_robot"
    goal: Pose2D | None = None
    _goal_t: float = -math.inf
    _failures: int = 0
    _err_sum: float = 0.0
    _samples: int = 0

    def validate(self, view: FleetView) -> None:
        target = self.params.get("target")
        if not isinstance(target, str):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "follow_robot needs 'target': a robot name")
        view.robot_record(target)  # unknown → lists the robots
        if target == self.robot:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot '{self.robot}' cannot follow itself")
        for key, default in (("distance", 1.0), ("regoal_distance", 0.3)):
            v = self.params.setdefault(key, default)
            if not isinstance(v, int | float) or not (0 < v < math.inf):
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{key} must be > 0, got {v!r}")
        d = self.params.get("duration")
        if d is not None and (not isinstance(d, int | float) or not (0 < d < math.inf)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"duration must be > 0 s or null, got {d!r}")

    def step(self, ctx: TaskContext) -> Command:
        target = str(self.params["target"])
        duration = self.params.get("duration")
        if duration is not None and ctx.now - self.started >= float(duration):
            return self.succeed(ctx.now)
        if not ctx.view.robots.has(target):
            return self.fail(ctx.now, f"target robot '{target}' is gone")
        me, tp = ctx.pose(self.robot), ctx.pose(target)
        want = self._follow_point(ctx, me, tp)
        nav = self.navigator(ctx)
        regoal = self.goal is None or want.distance_to(self.goal) > float(self.params["regoal_distance"])
        if nav.state is NavState.FAILED and ctx.now - self._goal_t >= RETRY_S:
            self._failures += 1
            if self._failures >= MAX_FAILURES:
                return self.fail(ctx.now, f"cannot reach the follow point: {self.reason}")
            regoal = True
        if regoal:
            self.goal, self._goal_t = want, ctx.now
            nav.set_goal(want, ctx.now)
        cmd, state = self.drive(ctx)
        if state in (NavState.TRACKING, NavState.SUCCEEDED):
            self._failures = 0
        gap = me.distance_to(tp)
        self._err_sum += abs(gap - float(self.params["distance"]))
        self._samples += 1
        self.progress.update({"target": target, "gap": round(gap, 3),
                              "mean_gap_error": round(self._err_sum / self._samples, 3),
                              "holding": state is NavState.SUCCEEDED})
        return (0.0, 0.0) if state.done else cmd

    def _follow_point(self, ctx: TaskContext, me: Pose2D, tp: Pose2D) -> Pose2D:
        d = float(self.params["distance"])
        behind = Pose2D(tp.x - d * math.cos(tp.yaw), tp.y - d * math.sin(tp.yaw), tp.yaw)
        if self.navigator(ctx).costmap.is_free(behind.x, behind.y):
            return behind
        gap = max(me.distance_to(tp), 1e-6)  # fall back to the point on the line towards the follower
        ux, uy = (me.x - tp.x) / gap, (me.y - tp.y) / gap
        return Pose2D(tp.x + d * ux, tp.y + d * uy, math.atan2(-uy, -ux))
