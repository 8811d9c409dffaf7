"""Formation keeping: robots hold slots of a shape around a virtual centre that migrates to a goal.

The virtual centre starts at the robots' centroid and moves towards `goal` at `speed`, slowed while the
formation is out of shape (so the group waits for its stragglers). Robot i tracks its slot:
u_i = v_c + k (c + R(yaw) o_i − p_i). Slots are assigned once at the start by the Hungarian algorithm.
Outcome: formation error, the RMS distance of the robots from their slots.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from fleet.formations import SHAPES, assign_slots, check_kind, formation_offsets, heading_mean
from fleet.swarm.registry import register_behaviour
from fleet.swarm.types import BehaviourConfig, SwarmState


class FormationConfig(BehaviourConfig):
    type: str = "formation"
    shape: str = Field("grid", description=f"one of {', '.join(SHAPES)}")
    spacing: float = Field(1.5, gt=0, description="m between neighbouring slots")
    yaw: float | None = Field(None, description="formation heading, rad; null: the robots' mean heading")
    goal: tuple[float, float] | None = Field(None, description="where the centre migrates to (x, y)")
    speed: float = Field(0.3, gt=0, description="migration speed of the centre, m/s")
    gain: float = Field(0.8, gt=0, description="slot tracking gain, 1/s")
    slowdown_error: float = Field(0.5, gt=0, description="the centre stops while the RMS error exceeds this, m")
    tolerance: float = Field(0.15, gt=0, description="converged below this RMS error (at the goal, if any), m")


@register_behaviour("formation", FormationConfig, min_robots=2)
class FormationKeeping:
    name = "formation"
    separates_itself = True  # its own law keeps the robots apart: avoidance only against outsiders

    def __init__(self, *, shape: str = "grid", spacing: float = 1.5, yaw: float | None = None,
                 goal: tuple[float, float] | None = None, speed: float = 0.3, gain: float = 0.8,
                 slowdown_error: float = 0.5, tolerance: float = 0.15) -> None:
        self.shape, self.spacing, self.yaw = check_kind(shape, SHAPES), spacing, yaw
        self.goal = None if goal is None else np.asarray(goal, dtype=float)
        self.speed, self.gain, self.slow, self.tol = speed, gain, slowdown_error, tolerance
        self.centre = np.zeros(2)
        self.slots = np.zeros((0, 2))  # world-frame offsets, row per robot
        self._last = math.nan

    def start(self, state: SwarmState) -> None:
        self.centre = state.xy.mean(axis=0)
        yaw = heading_mean(state.yaw) if self.yaw is None else self.yaw
        c, s = math.cos(yaw), math.sin(yaw)
        off = formation_offsets(self.shape, len(state.names), self.spacing) @ np.array([[c, s], [-s, c]])
        self.slots = off[assign_slots(state.xy - self.centre, off)]
        self._last = state.time

    def _centre_velocity(self, err: float) -> np.ndarray:
        if self.goal is None:
            return np.zeros(2)
        d = self.goal - self.centre
        dist = float(np.hypot(*d))
        speed = min(self.speed * max(0.0, 1.0 - err / self.slow), dist)
        return d / max(dist, 1e-9) * speed

    def velocities(self, state: SwarmState) -> np.ndarray:
        dt = max(0.0, state.time - self._last)
        self._last = state.time
        vc = self._centre_velocity(self._error(state))
        self.centre = self.centre + vc * dt
        return np.asarray(vc + self.gain * (self.centre + self.slots - state.xy))

    def _error(self, state: SwarmState) -> float:
        e = self.centre + self.slots - state.xy
        return float(np.sqrt((e**2).sum(axis=1).mean()))

    def metrics(self, state: SwarmState) -> dict[str, float]:
        to_goal = 0.0 if self.goal is None else float(np.hypot(*(self.goal - self.centre)))
        return {"formation_error_m": self._error(state), "centre_to_goal_m": to_goal}

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        return metrics["formation_error_m"] <= self.tol and metrics["centre_to_goal_m"] <= self.tol
