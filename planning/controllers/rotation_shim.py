"""Turn in place toward the path before tracking it (nav2's RotationShimController), around any controller.

A tracker handed a path that starts behind the robot drives a wide forward arc, which near walls is
exactly what the reactive layer forbids. On each new path the shim rotates the robot on the spot while the
path's heading (toward a point `lookahead` ahead) is more than `angle` away, down to angle/4, then hands
over to the wrapped controller for the rest of that path (corners along the way are the tracker's job).
"""

from __future__ import annotations

import math

from planning.controllers.base import Controller, RateLimiter, angle_diff
from planning.controllers.reference import PathReference
from planning.nav_types import ControlOutput
from planning.types import Costmap
from sim.types import Pose2D


class RotationShim:
    def __init__(self, inner: Controller, *, max_w: float, max_alpha: float, angle: float = 0.8,
                 lookahead: float = 0.4, gain: float = 2.5) -> None:
        self.inner, self.name = inner, inner.name
        self.angle, self.lookahead, self.gain = angle, lookahead, gain
        self.limit = RateLimiter(max_v=0.0, max_w=max_w, max_a=0.0, max_alpha=max_alpha, min_v=0.0)
        self._ref: PathReference | None = None
        self._s = 0.0
        self._rotating = False
        self._done = False  # aligned once on this path: the tracker has it from now on

    def reset(self) -> None:
        self.inner.reset()
        self.limit.reset()
        self._ref, self._rotating = None, False

    def compute(self, pose: Pose2D, twist: tuple[float, float], ref: PathReference, *, now: float,
                costmap: Costmap | None = None) -> ControlOutput:
        hint = self._s if ref is self._ref else None
        if ref is not self._ref:
            self._ref, self._done = ref, False
        if self._done:
            return self.inner.compute(pose, twist, ref, now=now, costmap=costmap)
        self._s, lateral = ref.project(pose.x, pose.y, hint)
        x, y, _, _, _ = ref.at(self._s + self.lookahead)
        err = angle_diff(math.atan2(float(y) - pose.y, float(x) - pose.x), pose.yaw)
        near_end = ref.remaining(self._s) < self.lookahead  # the heading to a point under the robot is noise
        threshold = self.angle / 4 if self._rotating else self.angle
        if abs(err) > threshold and not near_end:
            if not self._rotating:  # engage: the tracker restarts from the measured twist afterwards
                self.inner.reset()
            self._rotating = True
            _, w = self.limit(0.0, self.gain * err, now, twist, 0.05)
            return ControlOutput(v=0.0, w=w, progress=self._s, cross_track=lateral)
        self._rotating, self._done = False, True
        self.limit.reset()
        return self.inner.compute(pose, twist, ref, now=now, costmap=costmap)
