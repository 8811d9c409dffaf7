"""Group consistency of loop closures (pairwise consistency as in Olson's single-cluster graph partitioning
and Mangelson et al. 2018 "PCM"), for closures that verified but disagree with the current graph.

One closure at a time, a verified loop that contradicts the estimate is removed again: on a log where a few
front-end steps are wrong (Radish orebro: corridor peaks 2 m off), every true loop across them is rejected —
measured, 33 of 35 rejected closures there were within 8 cm of the reference. Two closures a (t_a → s_a) and
b (t_b → s_b) that are both right predict each other through the short stretches of path between their
targets and between their sources, however wrong the long path between target and source is:
    z_b ≈ (X_ta⁻¹ X_tb)⁻¹ · z_a · (X_sa⁻¹ X_sb)
A set of pending closures that agree pairwise is strong evidence that the graph, not the closures, is wrong:
they are added together and the graph (whose wide-search edges are switchable, `slam.max_mixture`) gives way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between, se2_compose
from slam import se2


class LoopGroupConfig(StrictModel):
    enabled: bool = True
    min_size: int = Field(3, ge=2, description="pending closures that agree pairwise are added together "
                          "once there are this many")
    gate_xy: float = Field(0.3, gt=0, description="pairwise: predicted vs measured closure, m …")
    gate_per_m: float = Field(0.02, ge=0, description="… plus this per m of path between the two targets and "
                              "between the two sources")
    gate_yaw: float = Field(0.08, gt=0, description="rad")
    max_span: float = Field(10.0, gt=0, description="closures whose targets (or sources) are further apart "
                            "along the path than this cannot vouch for each other, m")
    outvote: int = Field(2, ge=1, description="a group may remove accepted closures it contradicts if it has "
                         "this many times as many members; otherwise the group is taken out again")
    max_pending: int = Field(100, ge=1, description="oldest pending closures are dropped beyond this")


@dataclass(frozen=True, slots=True)
class Pending:
    target: int
    source: int
    relative: se2.PoseTuple
    covariance: np.ndarray
    score: float
    inliers: float
    rmse: float


def consistent(a: Pending, b: Pending, poses: list[se2.PoseTuple], path: list[float],
               config: LoopGroupConfig) -> bool:
    """Whether closures a and b agree through the estimate's short stretches between their ends."""
    dt = se2_between(poses[a.target], poses[b.target])
    ds = se2_between(poses[a.source], poses[b.source])
    pred = se2_compose(se2_compose(se2_between(dt, (0.0, 0.0, 0.0)), a.relative), ds)
    e = se2_between(pred, b.relative)
    span = abs(path[a.target] - path[b.target]) + abs(path[a.source] - path[b.source])
    if span > config.max_span:
        return False
    return math.hypot(e[0], e[1]) <= config.gate_xy + config.gate_per_m * span and abs(e[2]) <= config.gate_yaw


def largest_group(pending: list[Pending], newest: int, poses: list[se2.PoseTuple], path: list[float],
                  config: LoopGroupConfig) -> list[int]:
    """Indices of a large set of pending closures that includes `newest` and agree pairwise (greedy clique:
    the members most connected to the rest first)."""
    new = pending[newest]
    cand = [k for k, p in enumerate(pending) if k != newest and consistent(p, new, poses, path, config)]
    # pairwise among the newest's neighbours only (the clique must contain the newest)
    ok = {(i, j): consistent(pending[i], pending[j], poses, path, config) for i in cand for j in cand if i < j}

    def agree(i: int, j: int) -> bool:
        return i == j or ok[(min(i, j), max(i, j))]

    cand.sort(key=lambda k: -sum(agree(k, j) for j in cand))
    group = [newest]
    for k in cand:
        if all(agree(k, g) for g in group[1:]):
            group.append(k)
    return group
