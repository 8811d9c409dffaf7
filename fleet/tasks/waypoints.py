"""follow_waypoints: a sequence once, a loop, or a patrol for n rounds, with a dwell at each waypoint.

Driven by planning.waypoints.WaypointFollower. Each arrival publishes `waypoint_reached` and each finished
round `round_completed`, so a patrol can be counted from the event bus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fleet.tasks.base import Command, TaskContext, pose_param, register_task
from fleet.tasks.basic import NavTask
from fleet.tasks.types import WorkProfile
from planning.nav_types import NavState, Waypoint
from planning.waypoints import WaypointFollower, WaypointMode, visit_order
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

MODES = ("sequence", "loop", "patrol")


def parse_waypoints(params: dict[str, Any]) -> list[Waypoint]:
    """`waypoints`: poses {x, y, yaw?, dwell_s?, use_yaw?} or [x, y(, yaw)]; `dwell_s` is the default dwell."""
    raw = params.get("waypoints")
    if not isinstance(raw, list | tuple) or not raw:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "follow_waypoints needs a non-empty list 'waypoints'",
                         "e.g. waypoints: [{x: 1, y: 0}, {x: 1, y: 1, dwell_s: 2}]")
    default_dwell = params.get("dwell_s", 0.0)
    out = []
    for i, w in enumerate(raw):
        dwell = w.get("dwell_s", default_dwell) if isinstance(w, dict) else default_dwell
        if not isinstance(dwell, int | float) or not (0 <= dwell < math.inf):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"waypoint {i}: dwell_s must be ≥ 0, got {dwell!r}")
        use_yaw = bool(w.get("use_yaw", False)) if isinstance(w, dict) else False
        out.append(Waypoint(pose_param({"wp": w}, "wp"), float(dwell), use_yaw))
    return out


def parse_mode(params: dict[str, Any]) -> tuple[WaypointMode, int | None]:
    mode = params.get("mode", "sequence")
    if mode not in MODES:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown waypoint mode '{mode}'", f"modes: {', '.join(MODES)}")
    rounds = params.get("rounds", 1)
    if rounds is not None and (not isinstance(rounds, int) or rounds < 1):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"rounds must be an integer ≥ 1 or null, got {rounds!r}",
                         "null repeats a loop or patrol until canceled")
    return cast("WaypointMode", mode), rounds


@register_task
@dataclass(eq=False)
class FollowWaypointsTask(NavTask):
    """Visit `waypoints` in `mode` (sequence | loop | patrol) for `rounds` rounds (null: until canceled);
    `skip_failed: true` moves on past an unreachable waypoint instead of failing."""

    type_name = "follow_waypoints"
    allocatable = True
    follower: WaypointFollower | None = None
    _seen: int = 0

    def validate(self, view: FleetView) -> None:
        parse_waypoints(self.params)
        parse_mode(self.params)

    @classmethod
    def work_profile(cls, params: dict[str, Any], view: FleetView) -> WorkProfile:
        wps = parse_waypoints(params)
        mode, rounds = parse_mode(params)
        if rounds is None and mode != "sequence":
            raise FleetError(ErrorCode.UNSUPPORTED, "an endless loop or patrol cannot be allocated",
                             "give 'rounds' a number")
        order = [i for i, _ in visit_order(len(wps), mode, rounds)]
        pts = np.array([[wps[i].pose.x, wps[i].pose.y] for i in order])
        length = float(np.hypot(*np.diff(pts, axis=0).T).sum()) if len(pts) > 1 else 0.0
        return WorkProfile(start=(float(pts[0, 0]), float(pts[0, 1])), end=(float(pts[-1, 0]), float(pts[-1, 1])),
                           length=length,
                           duration=sum(wps[i].dwell_s for i in order), path=pts)

    def begin(self, ctx: TaskContext) -> None:
        mode, rounds = parse_mode(self.params)
        self.follower = WaypointFollower(navigator=self.navigator(ctx), waypoints=parse_waypoints(self.params),
                                         mode=mode, rounds=rounds,
                                         skip_failed=bool(self.params.get("skip_failed", False)))
        self.follower.start(ctx.now)

    def step(self, ctx: TaskContext) -> Command:
        f = self.follower
        assert f is not None
        cmd = f.tick(ctx.now, ctx.pose(self.robot), ctx.twist(self.robot), ctx.view.latest_scan(self.robot))
        st = f.status(ctx.now)
        self._publish_visits(ctx, st.visits, done=st.state is NavState.SUCCEEDED)
        leg = st.leg
        self.progress = {"index": st.current_index, "round": st.current_round + 1, "visits": len(st.visits),
                         "rounds_completed": self._rounds_done(st.visits, st.state is NavState.SUCCEEDED),
                         "dwelling": st.dwelling, "distance_remaining": leg.distance_remaining if leg else None,
                         "note": st.reason}
        if st.state is NavState.SUCCEEDED:
            return self.succeed(ctx.now)
        if st.state is NavState.FAILED:
            return self.fail(ctx.now, st.reason)
        return cmd

    def cancel(self, reason: str) -> None:
        if self.follower is not None:
            self.follower.cancel()

    def _rounds_done(self, visits: tuple[Any, ...], finished: bool) -> int:
        if not visits:
            return 0
        return visits[-1].round + 1 if finished else visits[-1].round

    def _publish_visits(self, ctx: TaskContext, visits: tuple[Any, ...], done: bool) -> None:
        bus, mode = ctx.view, self.params.get("mode", "sequence")
        for v in visits[self._seen:]:
            prev_round = visits[self._seen - 1].round if self._seen else 0
            if v.round > prev_round:  # the first visit of a new round closes the previous one
                bus.publish(v.arrived_at, "round_completed", (self.robot,), f"{self.robot} finished {mode} round "
                            f"{prev_round + 1}", task=self.id, round=prev_round + 1, mode=mode)
            bus.publish(v.arrived_at, "waypoint_reached", (self.robot,), f"{self.robot} at waypoint {v.index}",
                        task=self.id, index=v.index, round=v.round + 1)
            self._seen += 1
        if done and visits:
            last = visits[-1].round + 1
            bus.publish(ctx.now, "round_completed", (self.robot,), f"{self.robot} finished {mode} round {last}",
                        task=self.id, round=last, mode=mode)
