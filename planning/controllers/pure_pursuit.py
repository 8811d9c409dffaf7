"""Regulated pure pursuit (Macenski et al. 2023, nav2's RPP): the geometric baseline.

Steer along the arc through a lookahead point; regulate the speed down on tight curvature, near obstacles
(costmap clearance) and when approaching the end of the path; rotate in place when the path is behind.
"""

from __future__ import annotations

import math

from pydantic import Field

from planning.controllers.base import ControllerConfig, RateLimiter, register_controller
from planning.controllers.reference import PathReference
from planning.nav_types import ControlOutput
from planning.types import Costmap
from sim.types import Pose2D


class PurePursuitConfig(ControllerConfig):
    type: str = "pure_pursuit"
    desired_linear_vel: float = Field(0.5, gt=0, description="cruise speed, m/s (capped by the robot)")
    lookahead_time: float = Field(1.0, gt=0, description="lookahead = speed × this, s")
    min_lookahead: float = Field(0.3, gt=0)
    max_lookahead: float = Field(0.9, gt=0)
    regulated_min_radius: float = Field(0.9, gt=0, description="slow down on arcs tighter than this, m")
    approach_dist: float = Field(0.6, gt=0, description="slow down within this distance of the end, m")
    min_approach_vel: float = Field(0.05, gt=0)
    cost_scaling_dist: float = Field(0.3, ge=0, description="slow down when clearance - radius < this, m")
    cost_scaling_gain: float = Field(1.0, gt=0, le=1.0)
    regulated_min_speed: float = Field(0.25, ge=0, description="floor of the curvature/proximity rules")
    rotate_to_heading_angle: float = Field(0.785, gt=0, description="rotate in place above this, rad")
    rotate_to_heading_vel: float = Field(1.5, gt=0, description="rad/s")
    nominal_dt: float = Field(0.05, gt=0, description="control period assumed on the first call, s")


@register_controller("pure_pursuit", PurePursuitConfig)
class RegulatedPurePursuit:
    name = "pure_pursuit"

    def __init__(self, *, max_v: float, max_w: float, max_a: float, max_alpha: float, min_linear: float = 0.0,
                 desired_linear_vel: float = 0.5, lookahead_time: float = 1.0, min_lookahead: float = 0.3,
                 max_lookahead: float = 0.9, regulated_min_radius: float = 0.9, approach_dist: float = 0.6,
                 min_approach_vel: float = 0.05, cost_scaling_dist: float = 0.3, cost_scaling_gain: float = 1.0,
                 regulated_min_speed: float = 0.25, rotate_to_heading_angle: float = 0.785,
                 rotate_to_heading_vel: float = 1.5, nominal_dt: float = 0.05) -> None:
        self.v_des = min(desired_linear_vel, max_v)
        self.max_w = max_w
        self.la_time, self.la_min, self.la_max = lookahead_time, min_lookahead, max_lookahead
        self.min_radius = regulated_min_radius
        self.approach_dist, self.min_approach_vel = approach_dist, min_approach_vel
        self.cost_dist, self.cost_gain = cost_scaling_dist, cost_scaling_gain
        self.regulated_min = regulated_min_speed
        self.rot_angle, self.rot_vel = rotate_to_heading_angle, min(rotate_to_heading_vel, max_w)
        self.nominal_dt = nominal_dt
        self.limit = RateLimiter(max_v=max_v, max_w=max_w, max_a=max_a, max_alpha=max_alpha, min_v=min_linear)
        self._ref: PathReference | None = None
        self._s = 0.0

    def reset(self) -> None:
        self.limit.reset()
        self._ref = None

    def compute(self, pose: Pose2D, twist: tuple[float, float], ref: PathReference, *, now: float,
                costmap: Costmap | None = None) -> ControlOutput:
        if ref is not self._ref:  # a new path: search it whole once, then locally
            self._ref, hint = ref, None
        else:
            hint = self._s
        self._s, lateral = ref.project(pose.x, pose.y, hint)

        # 1. lookahead point, scaled with the current speed, in the robot frame
        speed = abs(self.limit.previous(twist)[0])
        lookahead = min(max(speed * self.la_time, self.la_min), self.la_max)
        gx, gy, _, _, _ = ref.at(self._s + lookahead)
        dx, dy = float(gx) - pose.x, float(gy) - pose.y
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        dist2 = max(lx * lx + ly * ly, 1e-9)
        curvature = 2.0 * ly / dist2

        # 2. rotate in place when the path is well off our heading (and we are not at the very end)
        remaining = ref.remaining(self._s)
        heading_err = math.atan2(ly, lx)
        if abs(heading_err) > self.rot_angle and dist2 > 1e-4:
            v, w = 0.0, math.copysign(self.rot_vel, heading_err)
        else:
            v = self._regulated_speed(curvature, remaining, pose, ref, costmap)
            w = v * curvature
            if remaining < 1e-3:  # at the end: hold still
                v, w = 0.0, 0.0
        v, w = self.limit(v, w, now, twist, self.nominal_dt)
        return ControlOutput(v=v, w=w, progress=self._s, cross_track=lateral)

    def _regulated_speed(self, curvature: float, remaining: float, pose: Pose2D, ref: PathReference,
                         costmap: Costmap | None) -> float:
        v = min(self.v_des, float(ref.at(self._s)[3]))
        v = max(v, self.min_approach_vel)  # the profile is 0 at the end; the approach rule handles it
        v_in = v
        radius = 1.0 / max(abs(curvature), 1e-9)
        if radius < self.min_radius:  # curvature heuristic
            v *= radius / self.min_radius
        if costmap is not None and self.cost_dist > 0:  # proximity heuristic
            gap = costmap.clearance(pose.x, pose.y) - costmap.robot_radius
            if gap < self.cost_dist:
                v *= self.cost_gain * max(gap, 0.0) / self.cost_dist + (1 - self.cost_gain)
        v = max(v, min(self.regulated_min, v_in))
        if remaining < self.approach_dist:  # approach: slow down linearly to the end
            v = min(v, max(self.min_approach_vel, v * remaining / self.approach_dist))
        return max(v, 0.0)
