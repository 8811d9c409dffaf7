"""Interfaces of swarm behaviours: what a behaviour sees of its robots, and what it must provide."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sim.config import StrictModel


class BehaviourConfig(StrictModel):
    """Fields every behaviour accepts; the `type:` key picks the behaviour."""

    type: str


@dataclass(frozen=True, slots=True)
class SwarmState:
    """The robots of one behaviour in one control tick (rows in the behaviour's robot order).

    Behaviours steer the tracked point OFFSET ahead of each axle (`xy`), which follows a commanded planar
    velocity exactly (fleet/swarm/unicycle.py); `centre` is where the axle is."""

    names: tuple[str, ...]
    time: float
    dt: float  # control period, s
    xy: np.ndarray  # (n, 2) ground-truth positions of the tracked points
    centre: np.ndarray  # (n, 2) ground-truth positions of the axle centres
    yaw: np.ndarray  # (n,)
    v: np.ndarray  # (n,) measured forward speed
    w: np.ndarray  # (n,)
    radius: np.ndarray  # (n,) footprint circles
    max_v: np.ndarray  # (n,)
    offset: float  # m, tracked point ahead of the axle

    @property
    def heading(self) -> np.ndarray:
        return np.column_stack([np.cos(self.yaw), np.sin(self.yaw)])

    @property
    def velocity(self) -> np.ndarray:
        """(n, 2) planar velocity of each tracked point: v·h + offset·ω·h⊥."""
        h = self.heading
        return self.v[:, None] * h + (self.offset * self.w)[:, None] * np.column_stack([-h[:, 1], h[:, 0]])


class Behaviour(Protocol):
    """A swarm behaviour: desired planar velocities from the fleet state, and its measured outcome.

    `velocities` may return NaN rows for robots it does not drive (e.g. the leader of leader-follower)."""

    name: str
    separates_itself: bool  # True: avoidance leaves its robots to it among themselves (only outsiders count)

    def start(self, state: SwarmState) -> None:
        """Called once with the initial state (assign slots, remember the initial centroid...)."""
        ...

    def velocities(self, state: SwarmState) -> np.ndarray: ...

    def metrics(self, state: SwarmState) -> dict[str, float]:
        """The measurable outcome now (cohesion, coverage %, formation error...)."""
        ...

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        """Whether the behaviour has reached its goal state (records the convergence time once)."""
        ...
