"""Task types that need no planner: wait, stop. And go_to, the navigator-driven task others build on, and
return_home (go_to the robot's home)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fleet.tasks.base import Command, Task, TaskContext, pose_param, register_task
from fleet.tasks.types import WorkProfile
from planning.nav_types import NavState
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView
    from planning.navigator import Navigator


@register_task
@dataclass(eq=False)
class WaitTask(Task):
    """Stand still for `seconds` of sim time."""

    type_name = "wait"

    def validate(self, view: FleetView) -> None:
        s = self.params.get("seconds")
        if not isinstance(s, int | float) or not (0 <= s < math.inf):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"wait needs seconds ≥ 0, got {s!r}")

    def step(self, ctx: TaskContext) -> Command:
        left = self.started + float(self.params["seconds"]) - ctx.now
        self.progress = {"remaining_s": max(0.0, left)}
        return self.succeed(ctx.now) if left <= 1e-9 else (0.0, 0.0)


@register_task
@dataclass(eq=False)
class StopTask(Task):
    """Come to rest, then succeed."""

    type_name = "stop"

    def step(self, ctx: TaskContext) -> Command:
        v, w = ctx.twist(self.robot)
        return self.succeed(ctx.now) if abs(v) < 0.01 and abs(w) < 0.01 else (0.0, 0.0)


@dataclass(eq=False)
class NavTask(Task):
    """A task driven by a planning.Navigator built for its robot (costmap, planner, controller from config)."""

    nav: Navigator | None = None

    def navigator(self, ctx: TaskContext) -> Navigator:
        if self.nav is None:
            self.nav = ctx.view.make_navigator(self.robot, self.params.get("navigation"))
        return self.nav

    def drive(self, ctx: TaskContext) -> tuple[Command, NavState]:
        nav = self.navigator(ctx)
        cmd = nav.tick(ctx.now, ctx.pose(self.robot), ctx.twist(self.robot),
                       ctx.view.latest_scan(self.robot))
        st = nav.status(ctx.now)
        self.progress = {"distance_remaining": st.distance_remaining, "eta_s": st.eta_s,
                         "replans": st.replans, "recoveries": st.recoveries, "nav_state": st.state.value}
        if st.state is NavState.FAILED:
            self.reason = st.reason
        return cmd, st.state

    def cancel(self, reason: str) -> None:
        if self.nav is not None:
            self.nav.cancel()


@register_task
@dataclass(eq=False)
class GoToTask(NavTask):
    """Navigate to `goal` {x, y, yaw}; with `align_yaw: true` also turn to its heading."""

    type_name = "go_to"
    allocatable = True

    def validate(self, view: FleetView) -> None:
        pose_param(self.params)

    @classmethod
    def work_profile(cls, params: dict[str, Any], view: FleetView) -> WorkProfile:
        g = pose_param(params)
        return WorkProfile(start=(g.x, g.y), end=(g.x, g.y))

    def begin(self, ctx: TaskContext) -> None:
        self.navigator(ctx).set_goal(pose_param(self.params), ctx.now,
                                     align_yaw=bool(self.params.get("align_yaw", False)))

    def step(self, ctx: TaskContext) -> Command:
        cmd, state = self.drive(ctx)
        if state is NavState.SUCCEEDED:
            return self.succeed(ctx.now)
        if state is NavState.FAILED:
            return self.fail(ctx.now, self.reason or "navigation failed")
        return cmd


@register_task
@dataclass(eq=False)
class ReturnHomeTask(GoToTask):
    """Navigate to the robot's home (where it was spawned), turning to the home heading unless
    `align_yaw: false`."""

    type_name = "return_home"
    allocatable = False  # robot-specific: its goal depends on who does it

    def validate(self, view: FleetView) -> None:
        self.params["goal"] = view.robot_record(self.robot).home
        self.params.setdefault("align_yaw", True)
