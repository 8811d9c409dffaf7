"""Flocking (Reynolds 1987): separation, alignment and cohesion among neighbours, plus optional migration.

Each robot steers towards the weighted sum of: its own heading (inertia), its neighbours' mean heading
(alignment), the direction to their centroid (cohesion), away from robots too close (separation) and to a
migration goal; it flies at a constant cruise speed (slower when crowded). Outcome: cohesion radius (mean
distance to the flock centroid), alignment (polarisation |mean heading|, 1 = all parallel) and the smallest
gap between robots.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from fleet.swarm.registry import register_behaviour
from fleet.swarm.types import BehaviourConfig, SwarmState
from fleet.swarm.unicycle import pairwise, separation


class FlockingConfig(BehaviourConfig):
    type: str = "flocking"
    speed: float = Field(0.3, gt=0, description="cruise speed, m/s")
    neighbor_radius: float = Field(4.0, gt=0, description="m")
    separation_distance: float = Field(1.2, gt=0, description="centre distance below which robots push apart, m")
    w_separation: float = Field(2.5, ge=0)
    w_alignment: float = Field(1.0, ge=0)
    w_cohesion: float = Field(0.6, ge=0)
    w_inertia: float = Field(0.5, ge=0)
    goal: tuple[float, float] | None = Field(None, description="migration point (x, y)")
    w_goal: float = Field(0.5, ge=0)


@register_behaviour("flocking", FlockingConfig, min_robots=2)
class Flocking:
    name = "flocking"
    separates_itself = False  # separation is only one of three urges: avoidance keeps flockmates apart

    def __init__(self, *, speed: float = 0.3, neighbor_radius: float = 4.0, separation_distance: float = 1.2,
                 w_separation: float = 2.5, w_alignment: float = 1.0, w_cohesion: float = 0.6,
                 w_inertia: float = 0.5, goal: tuple[float, float] | None = None, w_goal: float = 0.5) -> None:
        self.speed, self.radius, self.sep = speed, neighbor_radius, separation_distance
        self.w = (w_separation, w_alignment, w_cohesion, w_inertia, w_goal)
        self.goal = None if goal is None else np.asarray(goal, dtype=float)

    def start(self, state: SwarmState) -> None:
        pass

    def velocities(self, state: SwarmState) -> np.ndarray:
        w_sep, w_ali, w_coh, w_in, w_goal = self.w
        h = state.heading
        rel, d = pairwise(state.xy)
        nb = (d < self.radius).astype(float)
        count = nb.sum(axis=1)
        has = count > 0
        mean_h = np.where(has[:, None], nb @ h / np.maximum(count, 1)[:, None], h)
        to_centre = np.where(has[:, None], (rel * nb[..., None]).sum(axis=1) / np.maximum(count, 1)[:, None], 0.0)
        coh = to_centre / np.maximum(np.hypot(*to_centre.T), 1.0)[:, None]  # unit beyond 1 m, linear inside
        steer = w_in * h + w_ali * mean_h + w_coh * coh + w_sep * separation(state.xy, self.sep)
        if self.goal is not None:
            g = self.goal - state.xy
            steer += w_goal * g / np.maximum(np.hypot(*g.T), 1e-9)[:, None]
        n = np.maximum(np.hypot(*steer.T), 1e-9)
        crowd = np.clip(np.min(d, axis=1) / self.sep, 0.3, 1.0)  # ease off while pushing apart
        return np.asarray(steer / n[:, None] * (self.speed * crowd)[:, None])

    def metrics(self, state: SwarmState) -> dict[str, float]:
        c = state.xy.mean(axis=0)
        _, d = pairwise(state.centre)
        gap = d - state.radius[:, None] - state.radius[None, :]
        return {"cohesion_radius_m": float(np.hypot(*(state.xy - c).T).mean()),
                "alignment": float(np.hypot(*state.heading.mean(axis=0))),
                "min_gap_m": float(gap.min()) if len(state.xy) > 1 else float("inf")}

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        return metrics["alignment"] > 0.95 and metrics["min_gap_m"] > 0
