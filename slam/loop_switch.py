"""Graph surgery for `slam.edge_switch`: which wide front-end edges a loop group names, moving one of them to
its alternative peak in the GTSAM graph, and undoing that when the group still does not fit."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import gtsam
import numpy as np

from sim.transforms import se2_between, se2_compose
from slam import se2
from slam.edge_switch import EdgeSwitchConfig, rank_edges
from slam.loop_groups import Pending
from slam.pose_graph import gaussian

if TYPE_CHECKING:
    from slam.log_slam import LogSlam

Edge = tuple[int, int, se2.PoseTuple, np.ndarray]  # (i, j, relative, covariance), as in LogSlam.edges


@dataclass(frozen=True, slots=True)
class Switched:
    edge: int  # the front-end edge e (pose e - 1 → pose e) that was moved
    index: int  # the new factor's index in the graph
    old_factor: gtsam.NonlinearFactor
    old_edge: Edge


def named_edges(slam: LogSlam, cfg: EdgeSwitchConfig, members: list[Pending],
                held: list[tuple[int, int]]) -> list[tuple[int, np.ndarray]]:
    """Wide front-end edges in the loops' common stretch whose score surface has a peak where the group wants
    the path moved, best supported first, with that move (world frame). `held`: (target, source) of the
    accepted closures; an edge one of them spans is not moved."""
    if not cfg.enabled:
        return []
    s = slam
    moves = np.array([se2_compose(s.poses[p.target], p.relative) for p in members])
    here = np.array([s.poses[p.source] for p in members])
    yaw = float(np.median(np.remainder(moves[:, 2] - here[:, 2] + math.pi, math.tau) - math.pi))
    if abs(yaw) > cfg.max_yaw:
        return []
    d = np.median(moves[:, :2] - here[:, :2], axis=0)
    lo, hi = max(p.target for p in members), min(p.source for p in members)
    cand = [e for e in range(lo + 1, hi + 1) if not any(t < e <= u for t, u in held)]
    ranked = rank_edges(cand, s.surfaces, s.poses, d, cfg)
    return [(e, d) for e, _ in ranked]


def switch_edge(slam: LogSlam, e: int, d: np.ndarray) -> Switched:
    """Move front-end edge e so that pose e (and the path after it) shifts by d."""
    s = slam
    moved = (s.poses[e][0] + float(d[0]), s.poses[e][1] + float(d[1]), s.poses[e][2])
    rel = se2_between(s.poses[e - 1], moved)
    k = next(k for k, (i, j, _, _) in enumerate(s.edges) if i == e - 1 and j == e)
    cov = s.edges[k][3]
    index, old = s.graph.swap(s.graph.chain[e], gtsam.BetweenFactorPose2(e - 1, e, gtsam.Pose2(*rel),
                                                                       gaussian(cov)))
    s.graph.chain[e] = index
    switched = Switched(e, index, old, s.edges[k])
    s.edges[k] = (e - 1, e, rel, cov)  # graph.g2o holds the moved edge
    return switched


def unswitch(slam: LogSlam, sw: Switched) -> None:
    """Put the edge's old factor back and re-optimise."""
    g = slam.graph
    g.chain[sw.edge] = g.swap(sw.index, sw.old_factor)[0]
    k = next(k for k, (i, j, _, _) in enumerate(slam.edges) if i == sw.edge - 1 and j == sw.edge)
    slam.edges[k] = sw.old_edge
    g.converge(max_steps=50)
    slam.refresh_poses()
