"""Two-hypothesis matching with a one-scan delayed decision, for wide (no-odometry) matches that score low.

A weak wide match can be a wrong peak: on Radish orebro (step 213) a scan looking into an unmapped corridor
matched 0.41 with a 93° wrong turn, while its true pose scored 0.31; the constant-velocity prediction then
carried the wrong turn into two more steps. One scan later the answer is plain: the next scan, searched from
each hypothesis, matches the map 0.74 from the right one and 0.56 from the wrong one. So when a wide match
scores below `below`, a second hypothesis is formed — the best match in a window half as large around the
motion prediction (or the prediction itself) — and the hypothesis whose own score plus the next scan's best
score from it is higher wins. Latency: one scan; cost: three more wide searches on such steps only.

With `to_lookahead` (default) that second hypothesis is handed to `slam.lookahead` instead (`alternative`):
here the next scan is matched on the map without either hypothesis' scan, from each one's prediction in the
same wide window, so both usually find the same match and the own score alone decides; the look-ahead carries
each hypothesis' chain and weighs its free-space consistency (orebro with range noise, seed 2: decided here,
step 213 took a 93° wrong turn, 5.5 m ATE; handed over, 0.50 m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between, se2_compose
from slam import se2
from slam.csm import CsmResult, MatchGrid, search
from slam.motion_models import MotionModelsConfig
from slam.motion_prior import at_window_edge


class HypothesesConfig(StrictModel):
    enabled: bool = True
    below: float = Field(0.5, gt=0, le=1, description="a wide match scoring below this gets a second "
                         "hypothesis (mean hit likelihood, after the prior penalty)")
    same_xy: float = Field(0.3, gt=0, description="hypotheses closer than this (and same_yaw) are one, m")
    same_yaw: float = Field(0.1, gt=0, description="rad")
    to_lookahead: bool = Field(True, description="the second hypothesis joins the look-ahead's hypotheses "
                               "(`slam.lookahead.choose`: the chain of next scans matched from it, and the "
                               "free-space term) instead of being decided here by the next scan's score alone, "
                               "which matches the next scan on the map without the hypothesis' scan")
    alt_min_score: float = Field(0.2, gt=0, lt=1, description="… and is kept down to this score (after the "
                                 "prior penalty): a scan looking into unmapped space scores ~0.25–0.3 at its "
                                 "true pose (orebro step 213 with noise or half the beams)")
    escalate: float = Field(1.0, ge=1, description="when the wide window finds no match, or only one on its "
                            "edge, search once more in a window this many times larger (yaw capped at ±π; 1: "
                            "off). Off: at 2, orebro with every 2nd scan dropped went 15 → 6–10 m (still "
                            "broken), but seattle so went 0.045 → 21 m (a wrong match where the odometry's "
                            "window found none)")
    models: MotionModelsConfig = Field(MotionModelsConfig(), description="a step without odometry whose "
                                       "constant-velocity match is doubtful also searches windows seeded by "
                                       "other motion models; their matches join the look-ahead "
                                       "(`slam.motion_models`)")


@dataclass(frozen=True, slots=True)
class WideSearch:
    """The wide window's parameters, as `LogSlam` calls `slam.csm.search`."""

    window_xy: float
    window_yaw: float
    min_score: float
    weight_xy: float
    weight_yaw: float

    def run(self, grid: MatchGrid, points: np.ndarray, guess: se2.PoseTuple, shrink: float = 1.0
            ) -> CsmResult | None:
        return search(grid, points, guess, window_xy=self.window_xy * shrink,
                      window_yaw=min(self.window_yaw * shrink, math.pi),
                      min_score=self.min_score, top_level=4, max_range_for_step=5.0, prior_weight_xy=self.weight_xy,
                      prior_weight_yaw=self.weight_yaw)

    def at_edge(self, pose: se2.PoseTuple, guess: se2.PoseTuple, resolution: float, shrink: float = 1.0) -> bool:
        """The match lies on the window's boundary (`slam.motion_prior.at_window_edge`); a ±π yaw window has
        no yaw edge."""
        yaw = self.window_yaw * shrink
        return at_window_edge(pose, guess, self.window_xy * shrink, yaw if yaw < math.pi else math.inf, resolution,
                              math.radians(2))


def decide(grid: MatchGrid, points: np.ndarray, best: CsmResult, prev: se2.PoseTuple, guess: se2.PoseTuple,
           next_points: np.ndarray | None, wide: WideSearch, config: HypothesesConfig) -> CsmResult | None:
    """`best` (the wide match of `points` from `guess`) or the alternative near `guess`, whichever makes the
    next scan match better; None means the alternative is the bare prediction (no match near it)."""
    if not config.enabled or next_points is None or len(next_points) < 10 or best.score >= config.below:
        return best
    alt = wide.run(grid, points, guess, shrink=0.5)
    alt_pose = guess if alt is None else alt.pose
    d = se2_between(best.pose, alt_pose)
    if math.hypot(d[0], d[1]) < config.same_xy and abs(d[2]) < config.same_yaw:
        return best

    def lookahead(pose: se2.PoseTuple) -> float:
        step = se2_between(prev, pose)  # constant velocity from this hypothesis
        nxt = wide.run(grid, next_points, se2_compose(pose, step))
        return 0.0 if nxt is None else nxt.score

    alt_score = 0.0 if alt is None else alt.score
    if alt_score + lookahead(alt_pose) > best.score + lookahead(best.pose):
        return alt
    return best


def escalated(wide: WideSearch, grid: MatchGrid, points: np.ndarray, guess: se2.PoseTuple, factor: float
              ) -> CsmResult | None:
    """The wide search's match in a window `factor` times larger, for a step the wide window found nothing
    in (or only a match on its edge, a cut slope); None if that too finds none off its own edge."""
    if factor <= 1.0:
        return None
    res = wide.run(grid, points, guess, shrink=factor)
    if res is None or wide.at_edge(res.pose, guess, grid.resolution, factor):
        return None
    return res


def alternative(grid: MatchGrid, points: np.ndarray, best: CsmResult, guess: se2.PoseTuple, wide: WideSearch,
                config: HypothesesConfig) -> CsmResult | None:
    """The second hypothesis of a weak wide match `best` (as `decide` forms it, down to `alt_min_score`), for
    the look-ahead to weigh; None if `best` is strong, or the alternative is none or the same pose."""
    if not config.enabled or best.score >= config.below:
        return None
    alt = search(grid, points, guess, window_xy=wide.window_xy / 2, window_yaw=wide.window_yaw / 2,
                 min_score=config.alt_min_score, top_level=4, max_range_for_step=5.0,
                 prior_weight_xy=wide.weight_xy, prior_weight_yaw=wide.weight_yaw)
    if alt is None:
        return None
    d = se2_between(best.pose, alt.pose)
    return None if math.hypot(d[0], d[1]) < config.same_xy and abs(d[2]) < config.same_yaw else alt
