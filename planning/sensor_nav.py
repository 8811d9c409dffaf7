"""Navigation on what the robot's own lidar sees: `map_source: sensors | prior | both`.

Every tick the latest scan goes into a growing ObstacleMap (marking + raytrace clearing), the navigation
function (cost-to-go to the goal over the map, unknown space traversable-with-cost) is recomputed when the
map changed and `replan_period_s` has passed, and the footprint-exact dynamic-window controller picks the
twist. When nothing admissible is left, or the robot stops making progress, recoveries escalate: rotate in
place toward the route, back up, wait, then replan with half the safety margin (down to `min_margin`).
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from planning.controllers.footprint_dwa import DwaConfig, FootprintDwa
from planning.nav_types import NavState, NavStatus
from planning.navfn import FieldParams, NavField
from planning.obstacle_map import ObstacleMap
from planning.rect_footprint import RectFootprint
from sim.config import StrictModel
from sim.robot_spec import RobotSpec
from sim.types import LidarScan, Pose2D, WorldDescription

MapSource = Literal["sensors", "prior", "both"]


class SensorNavConfig(StrictModel):
    map_source: MapSource = Field("sensors", description="sensors: lidar only (no world file); prior: the "
                                  "world's obstacles; both: prior map corrected by the lidar")
    unknown: Literal["optimistic", "pessimistic"] = "optimistic"
    margin: float = Field(0.05, ge=0, description="safety margin between footprint and obstacles, m")
    min_margin: float = Field(0.03, ge=0, description="smallest margin a recovery replan may fall back to, m")
    resolution: float = Field(0.05, gt=0)
    map_margin: float = Field(3.0, ge=0, description="the map covers start and goal plus this, m (grows later)")
    replan_period_s: float = Field(0.3, gt=0)
    obstacle_max_range: float = Field(6.0, gt=0, description="lidar returns farther than this are not mapped, m")
    goal_tolerance: float = Field(0.3, gt=0)
    progress_timeout_s: float = Field(4.0, gt=0)
    timeout_s: float | None = Field(None, gt=0)
    inflation_radius: float = 0.8
    cost_weight: float = 4.0
    cost_decay: float = 5.0
    unknown_cost: float = 0.3
    dwa: DwaConfig = DwaConfig()


class SensorNavigator:
    """tick(now, pose, twist, scan) → (v, ω), like planning.Navigator, on a map built from the scans."""

    def __init__(self, cfg: SensorNavConfig, spec: RobotSpec, *, control_dt: float,
                 prior: WorldDescription | None = None) -> None:
        self.cfg, self.spec = cfg, spec
        self.footprint = RectFootprint.from_polygon(spec.footprint)
        self.sensor_offset = (spec.mast.x_offset, 0.0)
        lim = spec.limits
        self.control_dt = control_dt
        self.margin = cfg.margin
        self.dwa = FootprintDwa(cfg.dwa, footprint=self.footprint, margin=cfg.margin, max_v=lim.max_linear,
                                max_w=lim.max_angular, max_a=lim.max_linear_accel, max_alpha=lim.max_angular_accel,
                                control_dt=control_dt)
        self.omap = ObstacleMap((-1.0, -1.0, 1.0, 1.0), resolution=cfg.resolution,
                                obstacle_max_range=min(spec.sensors.lidar.range_max, cfg.obstacle_max_range),
                                raytrace_max_range=min(spec.sensors.lidar.range_max, cfg.obstacle_max_range))
        if cfg.map_source in ("prior", "both"):
            if prior is None:
                raise ValueError("map_source prior/both needs the world description")
            x0, y0, x1, y1 = prior.bounds(margin=1.0)
            self.omap.ensure((x0, y0, x1, y1))
            self.omap.add_prior(prior)
        self.field: NavField | None = None
        self.goal: Pose2D | None = None
        self.state = NavState.IDLE
        self.reason = ""
        self.replans = 0
        self.recoveries = 0
        self.events: list[tuple[float, str]] = []
        self._t0 = self._t_plan = self._t_end = 0.0
        self._best = math.inf
        self._t_best = 0.0
        self._recovery: list[tuple[str, float, float, float]] = []  # (kind, v, w, until)
        self._start = Pose2D(0.0, 0.0, 0.0)
        self._blocks: list[tuple[float, float, float]] = []  # pinch points the footprint could not pass

    def set_goal(self, goal: Pose2D, now: float, start: Pose2D) -> None:
        m = self.cfg.map_margin
        self.omap.ensure((min(start.x, goal.x) - m, min(start.y, goal.y) - m,
                          max(start.x, goal.x) + m, max(start.y, goal.y) + m))
        self.goal, self.state, self.reason, self._start = goal, NavState.PLANNING, "", start
        self._t0 = self._t_best = now
        self._best = math.inf
        self.field = None

    def status(self) -> NavStatus:
        return NavStatus(state=self.state, reason=self.reason, replans=self.replans, recoveries=self.recoveries,
                         goal=self.goal)

    # ---- the tick -------------------------------------------------------------------------------------

    def tick(self, now: float, pose: Pose2D, twist: tuple[float, float], scan: LidarScan | None) -> tuple[float, float]:
        if self.goal is None or self.state.done:
            return (0.0, 0.0)
        if scan is not None and self.cfg.map_source in ("sensors", "both"):
            self.omap.integrate_scan(scan, pose, self.sensor_offset)
        if pose.distance_to(self.goal) <= self.cfg.goal_tolerance:
            return self._finish(now, NavState.SUCCEEDED, "")
        if self.cfg.timeout_s is not None and now - self._t0 > self.cfg.timeout_s:
            return self._finish(now, NavState.FAILED, f"timed out after {self.cfg.timeout_s:g} s")
        self._maybe_replan(now, pose)
        assert self.field is not None
        if self._recovery:
            return self._recover(now, pose)
        here = float(self.field.value([[pose.x, pose.y]])[0])
        if here < self._best - 0.1:
            self._best, self._t_best = here, now
        elif now - self._t_best > self.cfg.progress_timeout_s:
            self._begin_recovery(now, pose, f"no progress for {self.cfg.progress_timeout_s:g} s")
            self._block_ahead(pose)
            return (0.0, 0.0)
        choice = self.dwa.choose(pose, twist, self.field, self.omap)
        if choice.admissible == 0:
            self._begin_recovery(now, pose, "no admissible motion")
            return (0.0, 0.0)
        self.state = NavState.TRACKING
        return choice.v, choice.w

    def _maybe_replan(self, now: float, pose: Pose2D, force: bool = False) -> None:
        assert self.goal is not None
        stale = self.field is None or self.field.version != self.omap.version
        if self.field is not None and not force and (not stale or now - self._t_plan < self.cfg.replan_period_s):
            return
        self.omap.ensure((pose.x - 2.0, pose.y - 2.0, pose.x + 2.0, pose.y + 2.0))
        c = self.cfg
        params = FieldParams(margin=self.margin, inflation_radius=c.inflation_radius, cost_weight=c.cost_weight,
                             cost_decay=c.cost_decay, unknown=c.unknown, unknown_cost=c.unknown_cost)
        m, g = c.map_margin, self.goal
        window = (min(pose.x, g.x, self._start.x) - m, min(pose.y, g.y, self._start.y) - m,
                  max(pose.x, g.x, self._start.x) + m, max(pose.y, g.y, self._start.y) + m)
        self.field = NavField(self.omap, self.goal, self.footprint, params, window, self._blocks)
        if self._blocks and not self.field.reachable(pose.x, pose.y):  # the blocks closed every way: forget them
            self._blocks = []
            self.field = NavField(self.omap, self.goal, self.footprint, params, window)
        self._t_plan = now
        self.replans += 1

    # ---- recoveries -----------------------------------------------------------------------------------

    def _block_ahead(self, pose: Pose2D) -> None:
        """The route leads where the rectangle does not fit (the field only knows the centre): close the pinch
        0.35 m down the field from here so the next plan takes another way (forgotten if none is left)."""
        if self.field is None:
            return
        e = 0.05
        gx = float(self.field.value([[pose.x + e, pose.y]])[0] - self.field.value([[pose.x - e, pose.y]])[0])
        gy = float(self.field.value([[pose.x, pose.y + e]])[0] - self.field.value([[pose.x, pose.y - e]])[0])
        n = math.hypot(gx, gy)
        if n > 1e-9:
            self._blocks.append((pose.x - 0.35 * gx / n, pose.y - 0.35 * gy / n, 0.2))
            self.field = None  # replan at once

    def _begin_recovery(self, now: float, pose: Pose2D, why: str) -> None:
        assert self.field is not None
        self.recoveries += 1
        n = self.recoveries
        g = self.field.value([[pose.x + 0.05, pose.y]])[0] - self.field.value([[pose.x - 0.05, pose.y]])[0]
        h = self.field.value([[pose.x, pose.y + 0.05]])[0] - self.field.value([[pose.x, pose.y - 0.05]])[0]
        err = math.remainder(math.atan2(-h, -g) - pose.yaw, 2 * math.pi)
        w = math.copysign(min(1.5, self.spec.limits.max_angular), err)
        steps: list[tuple[str, float, float, float]] = [("rotate", 0.0, w, now + min(abs(err) / abs(w), 2.0))]
        if n % 2 == 0:
            steps.insert(0, ("backup", -0.2, 0.0, now + 1.0))
        if n % 3 == 0:
            steps.append(("wait", 0.0, 0.0, now + 3.0))
        if n >= 2 and self.margin > self.cfg.min_margin:
            self.margin = max(self.cfg.min_margin, self.margin / 2)
            self.dwa.margin = self.margin
            steps.append((f"replan with margin {self.margin:.3f} m", 0.0, 0.0, now))
        # the durations chain: each step runs after the previous one
        t, chained = now, []
        for kind, v, wv, until in steps:
            dur = until - now
            chained.append((kind, v, wv, t + dur))
            t += dur
        self._recovery = chained
        self.events.append((now, f"{why}; recovery: {', '.join(s[0] for s in steps)}"))
        self.state = NavState.RECOVERING
        self._t_best = now + (t - now)
        self._best = math.inf

    def _recover(self, now: float, pose: Pose2D) -> tuple[float, float]:
        while self._recovery and now >= self._recovery[0][3]:
            kind = self._recovery.pop(0)[0]
            if kind.startswith("replan"):
                self._maybe_replan(now, pose, force=True)
        if not self._recovery:
            self.state = NavState.TRACKING
            return (0.0, 0.0)
        kind, v, w, _ = self._recovery[0]
        # a recovery motion must itself be safe: check the footprint one step ahead
        nxt = Pose2D(pose.x + v * self.control_dt * math.cos(pose.yaw),
                     pose.y + v * self.control_dt * math.sin(pose.yaw), pose.yaw + w * self.control_dt)
        pts = self.omap.points_near(pose.x, pose.y, self.footprint.circumscribed + 0.5)
        d = self.footprint.distances([[nxt.x, nxt.y, nxt.yaw]], pts)[0]
        d0 = self.footprint.distances([[pose.x, pose.y, pose.yaw]], pts)[0]
        if d < min(self.cfg.min_margin, d0):  # would touch (or get closer while touching): skip this step
            self._recovery.pop(0)
            return (0.0, 0.0)
        return (v, w)

    def _finish(self, now: float, state: NavState, reason: str) -> tuple[float, float]:
        self.state, self.reason, self._t_end = state, reason, now
        return (0.0, 0.0)
