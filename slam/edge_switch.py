"""Which front-end edge a group of agreeing loop closures says is wrong (a discrete max-mixture decision).

When pending loop closures agree pairwise (`slam.loop_groups`) but the graph cannot take them, the usual cause
on a log without odometry is one wide match that took the wrong peak of an ambiguous score surface (a corridor:
Radish orebro step 117 matched 1.3 m backwards at the previous keyframe, 2.4 m from the truth). The group says
by how much the path after that step must move (d, a translation in the world frame). The wrong step is the
one whose own score surface has a peak at +d: its match is then the alternative peak the search nearly chose.
A max-mixture edge with that peak as a component expresses the same thing (Olson & Agarwal 2012), but gradient
steps from the wrong component never reach a peak 2 m away; the group's d names it directly.

Each wide match keeps its translation score surface (`match_covariance.translation_surface`, ±window on a
0.15 m lattice at the matched rotation) in the matched pose's frame, as drops below the best score.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between
from slam import se2


class EdgeSwitchConfig(StrictModel):
    enabled: bool = True
    prior_weight: float = Field(0.03, ge=0, description="score penalty per m² of a step's distance from the "
                                "previous step, when ranking the edges a group could move")
    max_drop: float = Field(0.25, gt=0, le=1, description="an edge may be moved to a pose scoring at most "
                            "this much below its match (mean hit likelihood)")
    radius: float = Field(0.25, gt=0, description="the peak may lie this far from the pose the group asks "
                          "for (lattice and loop noise), m")
    tries: int = Field(3, ge=1, description="edges tried per group, best supported first")
    max_yaw: float = Field(0.05, gt=0, description="only translations: the group's rotation disagreement must "
                           "be below this, rad")


@dataclass(frozen=True, slots=True)
class Surface:
    offsets: np.ndarray  # (k, 2) translations in the matched pose's frame, m
    drop: np.ndarray  # (k,) score − best score (≤ 0)

    @staticmethod
    def of(offsets_world: np.ndarray, scores: np.ndarray, pose: se2.PoseTuple, keep: float = 0.3) -> Surface:
        """Only offsets scoring within `keep` of the best are stored (a few % of the lattice: memory stays
        small on long logs without odometry)."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        drop = scores - float(scores.max())
        near = drop >= -keep
        local = offsets_world[near] @ np.array([[c, -s], [s, c]])  # world → pose frame: Rᵀ·d for each row
        return Surface(local.astype(np.float32), drop[near].astype(np.float32))

    def drop_near(self, d_local: np.ndarray, radius: float) -> float:
        """Best (highest) drop among lattice offsets within `radius` of `d_local`; −inf outside the window."""
        near = np.hypot(self.offsets[:, 0] - d_local[0], self.offsets[:, 1] - d_local[1]) <= radius
        return float(self.drop[near].max()) if near.any() else -math.inf


def rank_edges(candidates: list[int], surfaces: dict[int, Surface], poses: list[se2.PoseTuple],
               d_world: np.ndarray, config: EdgeSwitchConfig) -> list[tuple[int, float]]:
    """(node e, gain) of the candidates whose score surface supports moving pose e by `d_world` (a drop of at
    most `max_drop`), best first. The gain is the change of the wide search's own objective — match score
    minus a quadratic penalty on the step's distance from the constant-velocity prediction — if the step
    moved: the surface's drop, plus what the move does to the step's agreement with the previous step."""
    out: list[tuple[int, float]] = []
    for e in candidates:
        surf = surfaces.get(e)
        if surf is None or e < 2:
            continue
        c, s = math.cos(poses[e][2]), math.sin(poses[e][2])
        d_local = np.array([c * d_world[0] + s * d_world[1], -s * d_world[0] + c * d_world[1]])
        drop = surf.drop_near(d_local, config.radius)
        if drop < -config.max_drop:
            continue
        pred = np.array(se2_between(poses[e - 2], poses[e - 1])[:2])
        step = np.array(se2_between(poses[e - 1], poses[e])[:2])
        c, s = math.cos(poses[e - 1][2]), math.sin(poses[e - 1][2])
        moved = step + np.array([c * d_world[0] + s * d_world[1], -s * d_world[0] + c * d_world[1]])
        prior = config.prior_weight * (float(np.sum((step - pred) ** 2)) - float(np.sum((moved - pred) ** 2)))
        out.append((e, drop + prior))
    return sorted(out, key=lambda eg: -eg[1])
