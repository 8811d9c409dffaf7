"""The navigator: goal → plan → track → replan when blocked or off-path → recover → succeeded | failed | canceled.

It knows nothing about sim.World: the caller feeds it the pose, twist and latest scan each control tick and
applies the (v, ω) it returns. Besides goals it can follow a given route (a coverage path): it plans only the
approach to the route (and detours back onto it after a replan) and tracks the route itself.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from planning.controllers.base import Controller, make_controller
from planning.controllers.recovery import Recovery, RecoveryConfig
from planning.controllers.reference import PathReference
from planning.controllers.rotation_shim import RotationShim
from planning.global_planners import get_planner
from planning.nav_types import ControlOutput, NavState, NavStatus
from planning.reactive import NoSafety, ReactiveConfig, ReactiveLayer, make_reactive
from planning.trajectory import smooth_path
from planning.types import Costmap, GlobalPlanner, PlanResult
from sim.config import StrictModel
from sim.errors import ErrorCode, FleetError
from sim.robot_spec import RobotSpec
from sim.types import LidarScan, Pose2D

STOP = (0.0, 0.0)


class NavigatorConfig(StrictModel):
    """The `navigation:` section: plugins by `type:`, the safety layer, recovery and tolerances."""

    planner: dict[str, Any] = Field(default_factory=lambda: {"type": "guided_theta_star"})
    controller: dict[str, Any] = Field(default_factory=lambda: {"type": "mpc_osqp"})
    rotate_to_heading_angle: float | None = Field(
        0.8, gt=0, description="turn in place first when the path heads further away than this, rad (null: off)")
    reactive: ReactiveConfig | None = Field(default_factory=ReactiveConfig, description="null: no safety layer")
    recovery: RecoveryConfig = Field(default_factory=RecoveryConfig)
    max_lat_accel: float = Field(0.5, gt=0, description="speed profile: v²·|κ| ≤ this, m/s²")
    smooth_radius: float = Field(0.5, ge=0, description="round plan corners up to this radius (0: off), m")
    goal_tolerance: float = Field(0.15, gt=0, description="m")
    yaw_tolerance: float = Field(0.1, gt=0, description="rad, when the goal heading matters")
    off_path_distance: float = Field(0.5, gt=0, description="replan beyond this cross-track error, m")
    progress_timeout_s: float = Field(10.0, gt=0, description="recover after this long without progress")
    min_progress: float = Field(0.1, gt=0, description="m of remaining distance that count as progress")
    max_recoveries: int = Field(4, ge=0)
    timeout_s: float | None = Field(None, gt=0)
    replan_period_s: float | None = Field(None, gt=0, description="null: replan only on events")
    map_source: Literal["prior", "sensors", "both"] = Field(
        "prior", description="prior: the world's obstacles; sensors: only what the lidar saw (unknown space "
        "traversable); both: the prior map corrected by the lidar")
    sense_period_s: float = Field(0.2, gt=0, description="with sensors/both: fold the scan into the costmap "
                                  "this often, and replan when the path ahead became blocked, s")
    progress_radius: float = Field(0.5, gt=0, description="with sensors/both: moving this far also counts as "
                                   "progress (nav2's progress checker), as exploring lengthens the route, m")
    clear_radius: float = Field(1.0, ge=0, description="with sensors/both: the 'clear costmap' recovery forgets "
                                "the scans only this close to the robot; the rest is the map it has built, m")
    block_horizon: float = Field(2.0, gt=0, description="with sensors/both: a newly seen obstacle this close "
                                 "along the path replans at once; farther ones every block_replan_s, m")
    block_replan_s: float = Field(1.0, gt=0, description="see block_horizon, s")


def make_navigator(config: NavigatorConfig, *, costmap: Costmap, spec: RobotSpec) -> Navigator:
    """Build planner, controller, safety layer and recovery from the config and the robot's limits."""
    lim = spec.limits
    safety: ReactiveLayer | NoSafety = NoSafety() if config.reactive is None else make_reactive(
        config.reactive, footprint=spec.footprint, max_a=lim.max_linear_accel,
        lidar_offset=(spec.mast.x_offset, 0.0))
    controller: Controller = make_controller(config.controller, lim)
    if config.rotate_to_heading_angle is not None:
        controller = RotationShim(controller, max_w=lim.max_angular, max_alpha=lim.max_angular_accel,
                                  angle=config.rotate_to_heading_angle)
    return Navigator(planner=get_planner(**config.planner), costmap=costmap, controller=controller, safety=safety,
                     recovery=Recovery(**config.recovery.model_dump()), max_v=lim.max_linear,
                     max_a=lim.max_linear_accel, max_w=lim.max_angular,
                     **config.model_dump(exclude={"planner", "controller", "reactive", "recovery",
                                                   "rotate_to_heading_angle"}))


class Navigator:
    """Goal → plan → track → replan → recover; `tick` is called once per control period by the owner."""

    # per-goal state, all (re)set by _start
    _goal: Pose2D | None
    _route: Route | None
    _ref: PathReference | None
    _pending: str | None  # why the next tick must (re)plan
    _scan: LidarScan | None
    _pose: Pose2D | None
    _check_pose: Pose2D | None
    _recovery_pose: Pose2D | None
    _t0: float
    _t_last: float
    _t_end: float

    def __init__(self, *, planner: GlobalPlanner, costmap: Costmap, controller: Controller,
                 safety: ReactiveLayer | NoSafety, recovery: Recovery, max_v: float, max_a: float,
                 max_w: float, max_lat_accel: float = 0.5, smooth_radius: float = 0.5, goal_tolerance: float = 0.15,
                 yaw_tolerance: float = 0.1, off_path_distance: float = 0.5, progress_timeout_s: float = 10.0,
                 min_progress: float = 0.1, max_recoveries: int = 4, timeout_s: float | None = None,
                 replan_period_s: float | None = None, map_source: str = "prior",
                 sense_period_s: float = 0.2, progress_radius: float = 0.5, clear_radius: float = 1.0,
                 block_horizon: float = 2.0, block_replan_s: float = 1.0) -> None:
        self.planner, self.costmap, self.controller = planner, costmap, controller
        self.safety, self.recovery = safety, recovery
        self.max_v, self.max_a, self.max_w, self.max_lat = max_v, max_a, max_w, max_lat_accel
        self.smooth_radius = smooth_radius
        self.goal_tol, self.yaw_tol, self.off_path = goal_tolerance, yaw_tolerance, off_path_distance
        self.progress_timeout, self.min_progress = progress_timeout_s, min_progress
        self.max_recoveries, self.timeout, self.replan_period = max_recoveries, timeout_s, replan_period_s
        self.sensing = map_source != "prior"  # the costmap learns from every scan, not only at replans
        self.sense_period, self._t_sensed = sense_period_s, -math.inf
        self.progress_radius, self.clear_radius = progress_radius, clear_radius
        self.block_horizon, self.block_replan_s = block_horizon, block_replan_s
        self.plans: list[PlanResult] = []  # every plan made for the current goal (for diagnostics)
        self.events: list[tuple[float, str]] = []  # (sim time, why) of every replan and recovery
        self._start(0.0, None, None, False)

    # ---- commands ------------------------------------------------------------------------------------

    def set_goal(self, goal: Pose2D, now: float, *, align_yaw: bool = False) -> None:
        """Drive to `goal` (and turn to goal.yaw on arrival when `align_yaw`)."""
        self._start(now, goal, None, align_yaw)

    def follow_route(self, path: np.ndarray, now: float) -> None:
        """Drive to the start of `path` (N, 2) and along it to its end (e.g. a coverage path)."""
        route = Route(np.asarray(path, dtype=float))
        self._start(now, route.end_pose(), route, False)

    def cancel(self) -> None:
        if not self._state.done and self._state is not NavState.IDLE:
            self.recovery.cancel()
            self._finish(NavState.CANCELED, "canceled by the caller")

    # ---- the control tick -----------------------------------------------------------------------------

    def tick(self, now: float, pose: Pose2D, twist: tuple[float, float],
             scan: LidarScan | None) -> tuple[float, float]:
        """One control step: the body twist (v, ω) to apply until the next tick."""
        if self._state is NavState.IDLE or self._state.done:
            return STOP
        dt, self._t_last, self._scan, self._pose = max(now - self._t_last, 0.0), now, scan, pose
        # 1. end conditions: arrived (then optionally turn to the goal's heading), or out of time
        if self._arrived(pose):
            return self._align_or_succeed(now, pose)
        if self.timeout is not None and now - self._t0 > self.timeout:
            return self._fail(f"timed out after {self.timeout:.1f} s")
        # 2. a running recovery owns the wheels until it is done
        if self._state is NavState.RECOVERING:
            return self._recover(now, pose)
        if self.sensing and scan is not None and now - self._t_sensed >= self.sense_period:
            self._sense(now, pose, scan)
        # 3. plan or replan when something asked for it (start, blocked, off path, stalled, period)
        if self._pending is not None and not self._replan(now, pose):
            return STOP
        # 4. track the path, then let the reactive layer veto or slow the command
        assert self._ref is not None
        out = self.controller.compute(pose, twist, self._ref, now=now, costmap=self.costmap)
        self._watch(now, dt, twist, out, pose)
        safe = self.safety.filter(out.v, out.w, scan, now)
        if safe.blocked:
            self._pending = "blocked by an obstacle"
        return safe.v, safe.w

    # ---- status ---------------------------------------------------------------------------------------

    @property
    def state(self) -> NavState:
        return self._state

    def status(self, now: float | None = None) -> NavStatus:
        if self._goal is None:
            return NavStatus(state=self._state)
        remaining = self._remaining()
        speed = self._speed if self._speed > 0.05 else self.max_v * 0.5
        end = self._t_end if self._state.done else (now if now is not None else self._t_last)
        return NavStatus(state=self._state, reason=self._reason, distance_remaining=remaining,
                         eta_s=0.0 if self._state.done else remaining / speed, elapsed_s=end - self._t0,
                         replans=max(0, len(self.plans) - 1), recoveries=self._recoveries,
                         path_length=self._ref.length if self._ref is not None else math.nan, goal=self._goal)

    # ---- steps of the tick ----------------------------------------------------------------------------

    def _start(self, now: float, goal: Pose2D | None, route: Route | None, align_yaw: bool) -> None:
        """Forget the previous goal; everything the tick keeps per goal is set here."""
        self.recovery.cancel()
        self.controller.reset()
        self.safety.reset()
        self.plans, self.events = [], []
        self._goal, self._route, self._align = goal, route, align_yaw
        self._state = NavState.IDLE if goal is None else NavState.PLANNING
        self._reason = ""
        self._pending = None if goal is None else "new goal"
        self._t0 = self._t_last = self._t_end = self._last_plan_t = now
        self._ref = None
        self._ref_s, self._speed = 0.0, 0.0  # progress along the reference; ~2 s average speed
        self._recoveries, self._attempt, self._recovered_at = 0, 0, math.inf
        self._check_t, self._check_remaining = now, math.inf  # stall detection
        self._check_pose = self._recovery_pose = None  # where the stall clock / the last recovery started
        self._scan, self._pose = None, None

    def _arrived(self, pose: Pose2D) -> bool:
        assert self._goal is not None
        if pose.distance_to(self._goal) > self.goal_tol:
            return False
        # a route must also be run to its end, not just pass near its last point
        return self._route is None or (self._ref is not None and self._remaining() <= 2 * self.goal_tol)

    def _align_or_succeed(self, now: float, pose: Pose2D) -> tuple[float, float]:
        assert self._goal is not None
        err = math.remainder(self._goal.yaw - pose.yaw, 2 * math.pi)
        if self._align and abs(err) > self.yaw_tol:
            safe = self.safety.filter(0.0, max(-self.max_w, min(self.max_w, 2.0 * err)), self._scan, now)
            return safe.v, safe.w
        self._finish(NavState.SUCCEEDED, "")
        return STOP

    def _replan(self, now: float, pose: Pose2D) -> bool:
        """Plan from here; on failure start a recovery. Returns True when there is a path to track."""
        reason, self._pending = self._pending, None
        if self._scan is not None:  # fold what the lidar sees into the costmap before planning
            self.costmap.update_from_scan(self._scan, pose)
        assert self._goal is not None
        try:
            start = self._nearest_free(pose, 0.3)  # stopped inside the inflation: start just outside it
            target, tail = (self._goal, None) if self._route is None else self._route.rejoin(self.costmap)
            if self._route is None:  # a goal grazed by scan noise may be reached anywhere within tolerance
                target = self._nearest_free(target, 0.8 * self.goal_tol)
            path = self._plan(pose, start, target)
        except FleetError as exc:
            if exc.code is not ErrorCode.PLANNING_FAILED:
                raise
            if self._route is None and not self._goal_free_without_scans():
                self._fail(f"planning failed: {exc.message}")  # no recovery can move a wall
            else:
                self._begin_recovery(now, f"planning failed: {exc.message}")
            return False
        if tail is not None:
            assert self._route is not None
            self._route.attach(approach_length=float(np.hypot(*np.diff(path, axis=0).T).sum()))
            path = np.vstack([path, tail[1:]])
        self._ref = PathReference.from_points(path, max_v=self.max_v, max_a=self.max_a, max_lat_a=self.max_lat)
        self._ref_s, self._last_plan_t = 0.0, now
        self._state, self._reason = NavState.TRACKING, reason or ""
        self.events.append((now, f"plan: {self._reason}"))
        self.safety.reset()  # a new path gets a full blocked timeout before it can ask for another
        return True

    def _plan(self, pose: Pose2D, start: Pose2D, target: Pose2D) -> np.ndarray:
        """A path from the robot to `target` (a straight hop when it is already there)."""
        if start.distance_to(target) < 2 * self.costmap.resolution:
            return np.array([[pose.x, pose.y], [target.x, target.y]])
        plan = self.planner.plan(start, target, self.costmap)
        self.plans.append(plan)
        # Not prefixed with the robot's own position when the start moved: a hop backwards would ask a
        # forward-only tracker to reverse; it joins the path from where it is instead.
        if self.smooth_radius > 0:  # shortcut + collision-checked corner arcs: faster, smoother tracking
            return smooth_path(plan.path, self.costmap, max_radius=self.smooth_radius)
        return plan.path

    def _sense(self, now: float, pose: Pose2D, scan: LidarScan) -> None:
        """Mark and clear the costmap from this scan; a path that now crosses an obstacle is replanned."""
        self._t_sensed = now
        self.costmap.update_from_scan(scan, pose)
        if self._ref is not None and self._pending is None and self._state is NavState.TRACKING:
            i = int(np.searchsorted(self._ref.s, self._ref_s))
            ahead = np.column_stack([self._ref.x[i:], self._ref.y[i:]])
            blocked = np.flatnonzero(~self.costmap.is_free_many(ahead)) if len(ahead) else ahead[:0, 0]
            # Near: replan now. Farther: at most once per block_replan_s — the optimistic route grazes the edge
            # of walls still being discovered, and replanning every scan for a wall metres away only dithers.
            if blocked.size and (self._ref.s[i + int(blocked[0])] - self._ref.s[i] <= self.block_horizon
                                 or now - self._last_plan_t >= self.block_replan_s):
                self._pending = "a newly seen obstacle blocks the path"

    def _watch(self, now: float, dt: float, twist: tuple[float, float], out: ControlOutput, pose: Pose2D) -> None:
        """Progress bookkeeping, and the reasons to replan: off the path, stalled, periodic."""
        self._ref_s = out.progress
        self._speed += min(1.0, dt / 2.0) * (abs(twist[0]) - self._speed)  # ~2 s moving average
        if self._route is not None:
            self._route.advance(out.progress)
        remaining = self._remaining()
        if abs(out.cross_track) > self.off_path:
            self._pending = f"off the path by {abs(out.cross_track):.2f} m"
        elif self.replan_period is not None and now - self._last_plan_t >= self.replan_period:
            self._pending = "periodic replan"
        # Exploring (sensors/both), each newly seen wall lengthens the route: moving on counts as progress too.
        moved = self.sensing and (self._check_pose is None
                                  or pose.distance_to(self._check_pose) > self.progress_radius)
        if remaining < self._check_remaining - self.min_progress or moved:  # progress: reset the stall clock
            self._check_t, self._check_remaining, self._check_pose = now, remaining, pose
            far = self.sensing and self._recovery_pose is not None and pose.distance_to(self._recovery_pose) > 1.0
            if self._attempt and (remaining < self._recovered_at - 1.0 or far):
                self._attempt = 0  # a metre of progress since the last recovery: start the ladder again
        elif now - self._check_t > self.progress_timeout:
            self._begin_recovery(now, f"no progress for {self.progress_timeout:.0f} s")

    def _begin_recovery(self, now: float, reason: str) -> None:
        self._attempt += 1
        if self._attempt > self.max_recoveries:
            self._fail(f"{reason} (after {self.max_recoveries} recoveries)")
            return
        self._recoveries += 1
        p = self._pose
        steps = self.recovery.begin(self._attempt, self.costmap, None if not self.sensing or p is None
                                    else (p.x, p.y, self.clear_radius))
        self._state, self._reason = NavState.RECOVERING, f"{reason}; recovery: {', '.join(steps)}"
        self.events.append((now, self._reason))
        self._recovered_at, self._recovery_pose = self._remaining(), self._pose
        self._check_t, self._check_remaining, self._check_pose = now, math.inf, None
        self.controller.reset()

    def _recover(self, now: float, pose: Pose2D) -> tuple[float, float]:
        cmd = self.recovery.step(now, pose)
        if cmd is None:  # recovery over: replan on the next tick
            self._state, self._pending = NavState.PLANNING, "after recovery"
            self.safety.reset()
            return STOP
        safe = self.safety.filter(cmd[0], cmd[1], self._scan, now)
        return safe.v, safe.w

    def _nearest_free(self, pose: Pose2D, radius: float) -> Pose2D:
        """`pose` if the planner may use it, else the nearest free point within `radius` (else `pose`, and
        the planner will say why)."""
        if self.costmap.is_free(pose.x, pose.y):
            return pose
        r = np.arange(self.costmap.resolution / 2, radius + 1e-9, self.costmap.resolution / 2)
        a = np.linspace(-math.pi, math.pi, 32, endpoint=False)
        pts = np.column_stack([(pose.x + np.outer(r, np.cos(a))).ravel(), (pose.y + np.outer(r, np.sin(a))).ravel()])
        free = np.flatnonzero(self.costmap.is_free_many(pts))
        if free.size == 0:
            return pose
        x, y = pts[free[0]]
        return Pose2D(float(x), float(y), pose.yaw)

    def _goal_free_without_scans(self) -> bool:
        assert self._goal is not None
        g = self._goal
        # with sensors/both only near the goal: the rest of what the scans built is the robot's map
        self.costmap.clear_dynamic((g.x, g.y, self.costmap.robot_radius + 0.5) if self.sensing else None)
        return self.costmap.is_free(g.x, g.y)

    def _remaining(self) -> float:
        if self._ref is None:
            return math.nan
        if self._route is not None:
            return self._route.remaining()
        return self._ref.remaining(self._ref_s)

    def _fail(self, reason: str) -> tuple[float, float]:
        self._finish(NavState.FAILED, reason)
        return STOP

    def _finish(self, state: NavState, reason: str) -> None:
        self._state, self._reason, self._t_end = state, reason, self._t_last


class Route:
    """A fixed path the navigator follows (e.g. coverage), and how far along it the robot has come."""

    def __init__(self, path: np.ndarray) -> None:
        if path.ndim != 2 or path.shape[0] < 2 or path.shape[1] != 2 or not np.all(np.isfinite(path)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "a route needs >= 2 finite (x, y) points",
                             "pass an (N, 2) array")
        self.path = path
        self.ref = PathReference(xy=path, speed=np.ones(len(path)))  # geometry only
        self.cum = np.r_[0.0, np.cumsum(np.hypot(*np.diff(path, axis=0).T))]
        self.s = 0.0  # progress along the route, m
        self._join, self._approach, self._started = 0.0, 0.0, False

    def end_pose(self) -> Pose2D:
        (x, y), yaw = self.path[-1], float(self.ref.yaw[-1])
        return Pose2D(float(x), float(y), math.remainder(yaw, 2 * math.pi))

    def rejoin(self, costmap: Costmap, ahead: float = 0.5, step: float = 0.1) -> tuple[Pose2D, np.ndarray]:
        """Where to rejoin the route (its start first, later a free point ahead of the progress) and the
        rest of the route from there."""
        s = min(self.s + ahead, self.ref.length) if self._started else 0.0
        while s < self.ref.length and not costmap.is_free(*(float(v) for v in self.ref.at(s)[:2])):
            s = min(s + step, self.ref.length)
        x, y, yaw, _, _ = self.ref.at(s)
        self._join = s
        later = self.cum > s
        tail = np.vstack([[float(x), float(y)], self.path[later]])
        return Pose2D(float(x), float(y), math.remainder(float(yaw), 2 * math.pi)), tail

    def attach(self, approach_length: float) -> None:
        """The reference now is an approach of this length followed by the route from the join point."""
        self._approach, self._started = approach_length, True

    def advance(self, ref_progress: float) -> None:
        self.s = max(self.s, self._join + max(0.0, ref_progress - self._approach))

    def remaining(self) -> float:
        return max(0.0, self.ref.length - self.s)
