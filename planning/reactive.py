"""The local safety layer: lidar-only, for obstacles the map does not know (other robots, new boxes).

For a command (v, ω) it sweeps the robot's footprint along the arc the command would drive and finds the
travel distance d to the first lidar point the footprint would touch. Then:
- d ≤ safety_distance: stop (state STOPPED); ω is kept when turning on the spot is itself clear;
- otherwise v is capped so the robot can still brake to a halt `safety_distance` short of the point,
  v ≤ √(2·a_brake·(d − safety)), and scaled down linearly inside `slowdown_distance` (state SLOWING);
- ω is scaled with v so the robot stays on the arc that was checked;
- stopped for `blocked_timeout_s` of sim time in a row → `blocked`: the navigator should replan.
Rotation in place is checked by sweeping the footprint through the turn.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import Field, model_validator

from planning.nav_types import SafetyResult, SafetyState
from sim.config import StrictModel
from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan


class ReactiveConfig(StrictModel):
    safety_distance: float = Field(0.15, ge=0, description="stop this far (along the motion) from a point, m")
    slowdown_distance: float = Field(0.6, gt=0, description="start slowing down this far away, m")
    min_slow_scale: float = Field(0.3, gt=0, le=1, description="speed factor at the safety distance")
    brake_fraction: float = Field(0.8, gt=0, le=1, description="share of max deceleration to plan with")
    blocked_timeout_s: float = Field(1.0, gt=0)
    step: float = Field(0.02, gt=0, description="sweep sampling step along the motion, m")
    max_spin_check: float = Field(0.6, gt=0, description="rotation swept when turning in place, rad")

    @model_validator(mode="after")
    def _order(self) -> ReactiveConfig:
        if self.slowdown_distance <= self.safety_distance:
            raise ValueError("slowdown_distance must exceed safety_distance")
        return self


class ReactiveLayer:
    """Filters velocity commands against the latest scan. Footprint: its bounding rectangle in base_link."""

    def __init__(self, *, footprint: Sequence[tuple[float, float]], max_a: float,
                 lidar_offset: tuple[float, float] = (0.0, 0.0), safety_distance: float = 0.15,
                 slowdown_distance: float = 0.6, min_slow_scale: float = 0.3, brake_fraction: float = 0.8,
                 blocked_timeout_s: float = 1.0, step: float = 0.02, max_spin_check: float = 0.6) -> None:
        fp = np.asarray(footprint, dtype=float)
        if fp.ndim != 2 or fp.shape[0] < 3 or fp.shape[1] != 2:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "footprint needs >= 3 (x, y) vertices",
                             "pass the robot's footprint polygon in base_link")
        self.box = (float(fp[:, 0].min()), float(fp[:, 0].max()), float(fp[:, 1].min()), float(fp[:, 1].max()))
        self.radius = float(np.hypot(fp[:, 0], fp[:, 1]).max())
        self.lidar_offset = np.asarray(lidar_offset, dtype=float)
        self.safety, self.slowdown, self.min_scale = safety_distance, slowdown_distance, min_slow_scale
        self.a_brake = brake_fraction * max_a
        self.blocked_timeout, self.step, self.max_spin = blocked_timeout_s, step, max_spin_check
        self._stopped_since: float | None = None

    def reset(self) -> None:
        self._stopped_since = None

    def filter(self, v: float, w: float, scan: LidarScan | None, now: float) -> SafetyResult:
        """The command to send instead of (v, ω), given the latest scan (None: nothing known, pass)."""
        pts = self._points(scan)
        d = self.distance_to_collision(v, w, pts)
        if d <= self.safety:
            state, v_out, w_out = SafetyState.STOPPED, 0.0, 0.0
            if abs(v) >= 1e-6 and abs(w) >= 1e-6 and self.distance_to_collision(0.0, w, pts) > self.safety:
                w_out = w  # the arc is blocked but turning on the spot is not: let the heading change
        else:
            cap = math.sqrt(2.0 * self.a_brake * (d - self.safety))
            if d < self.slowdown:
                frac = (d - self.safety) / (self.slowdown - self.safety)
                cap = min(cap, abs(v) * (self.min_scale + (1.0 - self.min_scale) * frac))
            if abs(v) > cap:
                state, v_out = SafetyState.SLOWING, math.copysign(cap, v)
                w_out = w * (v_out / v)
            else:
                state, v_out, w_out = SafetyState.CLEAR, v, w
        blocked = self._update_blocked(state, w_out != 0.0, now)
        return SafetyResult(v=v_out, w=w_out, state=state, distance_to_collision=d, blocked=blocked,
                            clamped=(v_out, w_out) != (v, w))

    def distance_to_collision(self, v: float, w: float, pts: np.ndarray) -> float:
        """Travel (m; for a turn in place, radians × footprint radius) before the footprint touches a point."""
        if pts.shape[0] == 0 or (abs(v) < 1e-6 and abs(w) < 1e-6):
            return math.inf
        reach = self.slowdown + self.step
        if abs(v) >= 1e-6:
            kappa = w / v
            d = math.copysign(1.0, v) * np.arange(0.0, reach + 1e-9, self.step)
            th = kappa * d
            small = abs(kappa) < 1e-9
            xs = d if small else np.sin(th) / kappa
            ys = np.zeros_like(d) if small else (1.0 - np.cos(th)) / kappa
            travel = np.abs(d)
        else:  # turning in place: sweep the heading, report the distance the outermost corner travels
            th = math.copysign(1.0, w) * np.arange(0.0, self.max_spin + 1e-9, self.step / self.radius)
            xs, ys = np.zeros_like(th), np.zeros_like(th)
            travel = np.abs(th) * self.radius
        near = pts[np.hypot(pts[:, 0], pts[:, 1]) <= reach + self.radius]
        if near.shape[0] == 0:
            return math.inf
        # each sampled pose (k) against each point (m), in that pose's frame
        dx = near[None, :, 0] - xs[:, None]
        dy = near[None, :, 1] - ys[:, None]
        c, s = np.cos(th)[:, None], np.sin(th)[:, None]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        x0, x1, y0, y1 = self.box
        hit = np.any((lx >= x0) & (lx <= x1) & (ly >= y0) & (ly <= y1), axis=1)
        if not hit.any():
            return math.inf
        first = int(np.argmax(hit))  # report the last free sample: conservative by at most one step
        return float(travel[first - 1]) if first > 0 else 0.0

    def _points(self, scan: LidarScan | None) -> np.ndarray:
        if scan is None:
            return np.zeros((0, 2))
        return scan.points() + self.lidar_offset

    def _update_blocked(self, state: SafetyState, turning: bool, now: float) -> bool:
        if state is not SafetyState.STOPPED or turning:
            self._stopped_since = None
            return False
        if self._stopped_since is None:
            self._stopped_since = now
        return now - self._stopped_since >= self.blocked_timeout


class NoSafety:
    """Null object for the reactive layer (e.g. a test of the tracker alone): passes every command."""

    def reset(self) -> None:
        return None

    def filter(self, v: float, w: float, scan: LidarScan | None, now: float) -> SafetyResult:
        return SafetyResult(v=v, w=w, state=SafetyState.CLEAR, distance_to_collision=math.inf)


def make_reactive(config: ReactiveConfig, *, footprint: Sequence[tuple[float, float]], max_a: float,
                  lidar_offset: tuple[float, float] = (0.0, 0.0)) -> ReactiveLayer:
    return ReactiveLayer(footprint=footprint, max_a=max_a, lidar_offset=lidar_offset, **config.model_dump())
