"""Consensus / rendezvous: ṗ_i = k Σ_j a_ij (p_j − p_i) over the communication graph, plus separation.

With a symmetric graph the sum of all velocities is zero, so the centroid never moves; on the complete
graph each robot closes on it exponentially, p_i(t) − c = e^{−k·n·t} (p_i(0) − c) for single integrators.
Real robots cannot all stand on the centroid, so an antisymmetric separation term (which also leaves the
centroid alone) packs them around it. Outcome: spread (largest distance to the centroid), drift of the
centroid from where it started, and the convergence time (spread within `converge_radius`, robots at rest).
Positions are those of the tracked points (SwarmState.xy), whose velocities are exactly the commanded ones.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from fleet.swarm.registry import register_behaviour
from fleet.swarm.types import BehaviourConfig, SwarmState
from fleet.swarm.unicycle import pairwise, scale_uniformly, separation


class ConsensusConfig(BehaviourConfig):
    type: str = "rendezvous"
    gain: float = Field(0.1, gt=0, description="k, 1/s per neighbour")
    comm_radius: float | None = Field(None, gt=0, description="null: complete graph; else disc graph, m")
    separation_distance: float = Field(1.2, ge=0, description="distance robots keep, m")
    w_separation: float = Field(3.0, ge=0)
    converge_radius: float | None = Field(None, gt=0, description="null: a packing of the robots' discs")
    max_speed: float = Field(0.3, gt=0, description="all velocities are scaled by one factor to stay below this, "
                             "which keeps the centroid still, m/s")


def consensus_velocity(xy: np.ndarray, gain: float, comm_radius: float | None = None) -> np.ndarray:
    """−k L p: the Laplacian consensus law over the complete graph or the disc graph of `comm_radius`."""
    rel, d = pairwise(xy)
    a = np.isfinite(d) if comm_radius is None else d <= comm_radius
    return np.asarray(gain * (rel * a[..., None]).sum(axis=1))


@register_behaviour("rendezvous", ConsensusConfig, min_robots=2)
class Rendezvous:
    name = "rendezvous"
    separates_itself = True  # its own law keeps the robots apart: avoidance only against outsiders

    def __init__(self, *, gain: float = 0.1, comm_radius: float | None = None, separation_distance: float = 1.2,
                 w_separation: float = 3.0, converge_radius: float | None = None, max_speed: float = 0.3) -> None:
        self.gain, self.comm = gain, comm_radius
        self.sep, self.w_sep = separation_distance, w_separation
        self.converge_radius, self.max_speed = converge_radius, max_speed
        self.c0 = np.zeros(2)

    def start(self, state: SwarmState) -> None:
        self.c0 = state.xy.mean(axis=0)
        if self.converge_radius is None:  # n discs of diameter `sep` fit in a circle of about this radius
            self.converge_radius = self.sep * (0.5 + 0.6 * math.sqrt(len(state.names))) + 0.1

    def velocities(self, state: SwarmState) -> np.ndarray:
        u = consensus_velocity(state.xy, self.gain, self.comm) + self.w_sep * separation(state.xy, self.sep)
        return scale_uniformly(u, min(self.max_speed, float(state.max_v.min())))

    def metrics(self, state: SwarmState) -> dict[str, float]:
        c = state.xy.mean(axis=0)
        return {"spread_m": float(np.hypot(*(state.xy - c).T).max()),
                "centroid_drift_m": float(np.hypot(*(c - self.c0))),
                "speed_max": float(np.abs(state.v).max())}

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        assert self.converge_radius is not None
        return metrics["spread_m"] <= self.converge_radius and metrics["speed_max"] < 0.05
