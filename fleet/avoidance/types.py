"""Interfaces of multi-robot avoidance: the plugin config base and what a filter sees of the fleet."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.config import StrictModel


class AvoidanceConfig(StrictModel):
    """Fields every avoidance plugin accepts; the `type:` key picks the plugin."""

    type: str


@dataclass(frozen=True, slots=True)
class FleetFrame:
    """The fleet as a filter sees it in one control tick: one row per robot, arrays from the world table."""

    names: list[str]
    xy: np.ndarray  # (n, 2) ground-truth positions
    yaw: np.ndarray  # (n,)
    v: np.ndarray  # (n,) measured body twist
    w: np.ndarray  # (n,)
    radius: np.ndarray  # (n,) footprint circle
    max_v: np.ndarray  # (n,)
    max_w: np.ndarray  # (n,)
    cmd: np.ndarray  # (n, 2) desired (v, ω) before avoidance
    active: np.ndarray  # (n,) bool: driven by autonomy (shares avoidance), else passive (others avoid it fully)
    group: np.ndarray  # (n,) int: robots with the same group ≥ 0 keep apart by themselves (a swarm behaviour)
