"""Near-tied peaks of a wide match, decided by the scans that follow (a pruned multi-hypothesis look-ahead).

In a corridor whose walls repeat (doors, pillars) the wide search's score surface has peaks a period apart along
its axis that score within a few hundredths of each other. On Radish orebro (no odometry) step 17 took a peak
2 m behind the truth that scored 0.812 against the truth's 0.793 (both after the motion-prior penalty), and
nothing in scan 17 tells them apart. Carried two scans ahead, the truth wins (scans 18–19 match from it without
a jump). Step 117 is the other kind: a scan looking into an unmapped corridor scores 0.40 at its true pose (the
motion prediction) and 0.49 at a peak 2.4 m back, which puts 17 % of the returns where the local map's scans
saw through, against 7 % at the truth (`slam.see_through`).

So the hypotheses of a wide match are: itself; every distinct peak of its translation score surface (≥
`min_separation` away) that, refined by a small search, scores within `margin` of it; and the refined motion
prediction if it scores within `prediction_margin`. Each is carried `depth` scans ahead (the local map plus the
hypothesis' scans at their hypothesised poses; the next scan searched in the wide window from the
constant-velocity prediction, added, and so on). The winner has the highest sum of the wide search's own
objective (score minus the motion-prior penalty) minus `free_space_weight` × the free-space inconsistency of its
chain (its scan and the next scans at the poses found from it) with the older scans. Only the current scan's
decision is kept; the next scans are matched normally when they arrive. Cost: hypotheses × depth wide searches
and grid builds, on near-tied steps only (5 of 237 on orebro).

Why the whole chain: each chain's next scans are matched on a map holding the chain's own scan, so a chain one
corridor period off is self-consistent and its next scans score like the truth's (orebro with 3 cm range
noise or half the beams: the sums flipped by 0.02–0.09). What the older scans saw as free is the evidence no
hypothesis placed, and each scan of a wrong chain contradicts it again. It is counted as a share of all the
returns compared, not of those that overlap: the latter favours poses that overlap the older scans most.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between, se2_compose
from slam import se2
from slam.csm import CsmResult, MatchGrid, search
from slam.see_through import inconsistency

GridOf = Callable[[list[tuple[se2.PoseTuple, np.ndarray]]], MatchGrid]  # extra (pose, points) → local map
WideRun = Callable[[MatchGrid, np.ndarray, se2.PoseTuple], "CsmResult | None"]  # the wide search from a guess


class LookaheadConfig(StrictModel):
    enabled: bool = True
    margin: float = Field(0.05, ge=0, le=1, description="a distinct peak scoring within this of the best wide "
                          "match, once refined, is a hypothesis (mean hit likelihood)")
    min_separation: float = Field(0.5, gt=0, description="peaks closer than this to a kept one are the same, m")
    candidate_margin: float = Field(0.12, ge=0, le=1, description="surface peaks within this of the best are "
                                    "refined (the 0.15 m lattice samples a peak up to ~0.1 below its top)")
    max_candidates: int = Field(4, ge=1, description="… at most this many")
    max_hypotheses: int = Field(3, ge=2, description="the best match and at most this many − 1 alternatives")
    depth: int = Field(2, ge=1, description="scans carried ahead per hypothesis (3 measured: the same decisions "
                       "on orebro under 11 nearby settings, at 1.5× the cost)")
    prediction_margin: float = Field(0.15, ge=0, le=1, description="the motion prediction (refined) is a "
                                     "hypothesis too when it scores within this of the best, distinct peak or "
                                     "not: a scan looking into unmapped space scores low at its true pose")
    free_space_weight: float = Field(4.0, ge=0, description="a hypothesis loses this × the share of returns "
                                     "it puts in the local map's free space or lets the scan see through "
                                     "(slam.see_through)")
    free_space_chain: bool = Field(True, description="the free-space term sums over the hypothesis' whole chain "
                                   "(its scan and the next scans at the poses found from it), not its scan only: "
                                   "a chain one corridor period off is self-consistent, so its next scans' match "
                                   "scores tie with the truth's, but each of them again contradicts what the "
                                   "older scans saw as free")
    free_space_of_all: bool = Field(True, description="the free-space share counts the returns that contradict "
                                    "against all the returns compared, not only those that overlap: a share of "
                                    "the overlap favours poses that overlap the older scans most")
    free_space_margin: float = Field(0.3, gt=0, description="a return this much closer than the other scan's "
                                     "on its bearing was seen through, m")
    points: int = Field(40, ge=10, description="scan points scored by the look-ahead searches (80 measured: the "
                        "same decisions on orebro under 11 settings, at 2–3× the search cost)")
    refine_xy: float = Field(0.2, gt=0, description="each alternative is refined by a search ± this, m")
    refine_yaw: float = Field(math.radians(5), gt=0, description="… and ± this, rad")


def surface_peaks(offsets: np.ndarray, scores: np.ndarray, margin: float, separation: float, limit: int
                  ) -> list[np.ndarray]:
    """Offsets (world frame) of the best lattice points scoring within `margin` of the top, each at least
    `separation` from every better one and from the origin (the match itself), best first."""
    top = float(scores.max())
    kept: list[np.ndarray] = [np.zeros(2)]
    for k in np.argsort(-scores):
        if scores[k] < top - margin or len(kept) > limit:
            break
        if all(math.hypot(*(offsets[k] - q)) >= separation for q in kept):
            kept.append(offsets[k])
    return kept[1:]


def alternatives(grid: MatchGrid, points: np.ndarray, best: CsmResult, guess: se2.PoseTuple,
                 surface: tuple[np.ndarray, np.ndarray], config: LookaheadConfig, prior: tuple[float, float]
                 ) -> list[CsmResult]:
    """The refined distinct peaks near-tied with `best` (its score surface `surface` at best.pose's rotation),
    each scored with the same motion-prior penalty around `guess` as the wide search."""
    out: list[CsmResult] = []
    top = best.score
    peaks = surface_peaks(*surface, config.candidate_margin, config.min_separation, config.max_candidates)
    starts = [(best.pose[0] + float(d[0]), best.pose[1] + float(d[1]), best.pose[2]) for d in peaks]
    margins = [config.margin] * len(starts)
    if math.hypot(guess[0] - best.pose[0], guess[1] - best.pose[1]) >= config.min_separation:
        starts.append(guess)
        margins.append(config.prediction_margin)
    for start, margin in zip(starts, margins, strict=True):
        r = search(grid, points, start, window_xy=config.refine_xy, window_yaw=config.refine_yaw)
        if r is None:
            continue
        score = r.score - _penalty(r.pose, guess, prior)
        if score >= top - margin and all(math.hypot(r.pose[0] - h.pose[0], r.pose[1] - h.pose[1])
                                         >= config.min_separation for h in [best, *out]):
            out.append(CsmResult(r.pose, score, r.nodes))
    return sorted(out, key=lambda h: -h.score)[:config.max_hypotheses - 1]


def _penalty(pose: se2.PoseTuple, guess: se2.PoseTuple, prior: tuple[float, float]) -> float:
    d = se2_between(guess, pose)
    return prior[0] * (d[0] ** 2 + d[1] ** 2) + prior[1] * math.remainder(pose[2] - guess[2], math.tau) ** 2


Chain = list[tuple[se2.PoseTuple, np.ndarray]]  # a hypothesis' scan and the next scans, at their poses (map points)


def free_space_penalty(others: Sequence[tuple[se2.PoseTuple, np.ndarray]], config: LookaheadConfig
                       ) -> Callable[[Chain], float]:
    """`choose`'s penalty: `free_space_weight` × the free-space inconsistency of the chain's scans (or its
    first only) with the older scans `others` (pose, points), which no hypothesis placed."""
    def penalty(chain: Chain) -> float:
        scans = chain if config.free_space_chain else chain[:1]
        return config.free_space_weight * sum(inconsistency(p, q, others, config.free_space_margin,
                                                            config.free_space_of_all) for p, q in scans)
    return penalty


def choose(hypotheses: Sequence[CsmResult], prev: se2.PoseTuple, points: np.ndarray,
           following: Sequence[tuple[np.ndarray, np.ndarray]], grid_of: GridOf, wide: WideRun,
           penalty: Callable[[Chain], float] | None = None
           ) -> tuple[CsmResult, list[float]]:
    """The hypothesis whose own score plus the following scans' scores (each matched in the wide window from
    the constant-velocity prediction against the local map holding the hypothesis' scans) is highest.
    `points`: the current scan's map points; `following`: (search points, map points) of the next scans;
    `penalty`: of the chain (hypothesis and the next scans at the poses it found, with their map points)."""
    totals: list[float] = []
    for h in hypotheses:
        chain: Chain = [(h.pose, points)]
        last, before = h.pose, prev
        total = h.score
        for search_pts, map_pts in following:
            if len(search_pts) < 10:
                break
            r = wide(grid_of(chain), search_pts, se2_compose(last, se2_between(before, last)))
            if r is None:  # no match from this hypothesis: it earns nothing more
                break
            total += r.score
            chain.append((r.pose, map_pts))
            before, last = last, r.pose
        if penalty is not None:
            total -= penalty(chain)
        totals.append(total)
    return hypotheses[int(np.argmax(totals))], totals
