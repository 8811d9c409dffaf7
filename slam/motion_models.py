"""Wide-window seeds from several motion models, for a step without odometry whose constant-velocity match is
doubtful.

Without odometry the wide correlative window (±2.5 m, ±85°) is centred on the constant-velocity prediction
(`slam.motion_prior`). At a low scan rate that prediction is often wrong by more than the window: on Radish orebro
with every second scan dropped it is 2–5 m or up to 130° off at 21 of 117 steps (the robot stops after a
straight run, drives on after turning in place, or turns the other way). A bigger window was tried and broke a
log that matched fine (`slam.hypotheses.escalate`). Instead, other motion models each seed a window of the same
size: no motion (stopped, or turning in place: its window spans every heading), driving straight on without
turning at the median and at the top speed of the last steps. Their matches join the look-ahead's
hypotheses (`slam.lookahead.choose`), which decides by the chain of next scans and its free-space consistency
with the older scans. Cost: one wide search per distinct seed, only on steps the gate opens (the
constant-velocity match weak, on its window's edge, far from its prediction, or none) — a step matched well
near its prediction costs nothing more. Cartographer's pose extrapolator plays the same role with IMU and
odometry; this is what is left when there is neither.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between, se2_compose
from slam import se2
from slam.csm import CsmResult, MatchGrid

if TYPE_CHECKING:
    from slam.hypotheses import WideSearch

Model = Literal["zero", "straight", "fast", "median"]
WideRunFn = Callable[[MatchGrid, np.ndarray, se2.PoseTuple], "CsmResult | None"]  # the wide search from a seed
EdgeFn = Callable[[se2.PoseTuple, se2.PoseTuple, float], bool]  # (match, seed, resolution) → on the edge


class MotionModelsConfig(StrictModel):
    enabled: bool = False
    models: list[Model] = Field(["zero", "straight", "fast"], description="seeds besides constant velocity: "
                                "no motion; straight on at the median speed of the last steps; (fast) … at "
                                "their top speed; (median) the componentwise median of the last steps "
                                "(measured: deduplicated against the others nearly always, no gain)")
    steps: int = Field(5, ge=1, description="last steps the speed and the median are taken over")
    weak: float = Field(0.5, gt=0, le=1, description="the gate opens when the constant-velocity match scores "
                        "below this (after the prior penalty)")
    off_xy: float = Field(2.0, gt=0, description="… or lies this far from its prediction (the prediction was "
                          "poor, so the others may be better), m")
    off_yaw: float = Field(math.radians(60), gt=0, description="… or turned this far from it, rad (at 1 m / "
                           "30° it opened on 69 of 236 orebro steps and found one distinct match there)")
    distinct_xy: float = Field(1.0, gt=0, description="a seed this close to one already searched (and "
                               "distinct_yaw) is skipped: its window is mostly the same, m")
    distinct_yaw: float = Field(math.radians(30), gt=0, description="rad")
    full_turn: bool = Field(True, description="the no-motion seed searches every heading (±π) instead of the "
                            "wide window's yaw: turning in place can go any way")
    margin: float = Field(1.0, ge=0, le=1, description="a seeded match joins the look-ahead only if it scores "
                          "within this of the constant-velocity match (1: always)")
    alone_min_score: float = Field(0.5, gt=0, le=1, description="when the constant-velocity window found no "
                                   "match, another model's match is taken only if it scores this much (else the "
                                   "step keeps the prediction with a loose σ, which loop closures can move; a "
                                   "weak match is a tight wrong edge)")
    same_xy: float = Field(0.5, gt=0, description="matches this close to a kept one (and same_yaw) are one, m")
    same_yaw: float = Field(math.radians(10), gt=0, description="rad")


def model_steps(poses: list[se2.PoseTuple], config: MotionModelsConfig) -> list[se2.PoseTuple]:
    """The steps each model predicts next, in `config.models` order (none before two poses exist)."""
    if len(poses) < 2:
        return [(0.0, 0.0, 0.0)] if "zero" in config.models else []
    last = poses[-config.steps - 1:]
    recent = np.array([se2_between(a, b) for a, b in itertools.pairwise(last)])
    out: list[se2.PoseTuple] = []
    for m in config.models:
        if m == "zero":
            out.append((0.0, 0.0, 0.0))
        elif m in ("straight", "fast"):
            speed = np.hypot(recent[:, 0], recent[:, 1])
            out.append((float(np.median(speed) if m == "straight" else speed.max()), 0.0, 0.0))
        else:
            med = np.median(recent, axis=0)
            out.append((float(med[0]), float(med[1]), float(med[2])))
    return out


def gate(res: CsmResult | None, guess: se2.PoseTuple, config: MotionModelsConfig) -> bool:
    """Whether the constant-velocity match `res` (from `guess`) is doubtful enough to try the other models."""
    if not config.enabled:
        return False
    if res is None or res.score < config.weak:
        return True
    d = se2_between(guess, res.pose)
    return math.hypot(d[0], d[1]) > config.off_xy or abs(d[2]) > config.off_yaw


def _close(a: se2.PoseTuple, b: se2.PoseTuple, xy: float, yaw: float) -> bool:
    return math.hypot(a[0] - b[0], a[1] - b[1]) < xy and abs(math.remainder(a[2] - b[2], math.tau)) < yaw


def seeded_matches(run: WideRunFn, grid: MatchGrid, points: np.ndarray, prev: se2.PoseTuple,
                   guess: se2.PoseTuple, res: CsmResult | None, poses: list[se2.PoseTuple],
                   config: MotionModelsConfig, at_edge: EdgeFn, run_turn: WideRunFn | None = None
                   ) -> list[CsmResult]:
    """The wide matches from the other models' seeds that are distinct from `res` and from each other and not
    on their window's edge, best first. `run_turn`: the wide search over every heading (`full_turn`)."""
    searched = [guess]
    kept: list[CsmResult] = [] if res is None else [res]
    out: list[CsmResult] = []
    for step in model_steps(poses, config):
        seed = se2_compose(prev, step)
        if any(_close(seed, s, config.distinct_xy, config.distinct_yaw) for s in searched):
            continue
        searched.append(seed)
        turn = config.full_turn and run_turn is not None and step == (0.0, 0.0, 0.0)
        r = (run_turn if turn and run_turn is not None else run)(grid, points, seed)
        if r is None or at_edge(r.pose, seed if not turn else (seed[0], seed[1], r.pose[2]), grid.resolution):
            continue
        if any(_close(r.pose, k.pose, config.same_xy, config.same_yaw) for k in kept):
            continue
        kept.append(r)
        out.append(r)
    if res is not None:
        out = [r for r in out if r.score >= res.score - config.margin]
    out.sort(key=lambda h: -h.score)
    if res is None and out and out[0].score < config.alone_min_score:
        return []
    return out


def with_models(wide: WideSearch, grid: MatchGrid, points: np.ndarray, poses: list[se2.PoseTuple],
                guess: se2.PoseTuple, res: CsmResult | None, config: MotionModelsConfig
                ) -> tuple[CsmResult | None, list[CsmResult]]:
    """The match to go on with and the other models' matches for the look-ahead, when the gate opens: `res`
    (the constant-velocity match of `points` from `guess`), or the best seeded match if `res` is None."""
    if not gate(res, guess, config):
        return res, []
    out = seeded_matches(wide.run, grid, points, poses[-1], guess, res, poses, config, wide.at_edge,
                         dataclasses.replace(wide, window_yaw=math.pi).run)
    return (res, out) if res is not None or not out else (out[0], out[1:])
