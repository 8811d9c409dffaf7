"""Motion prior of a scan step when the log has no odometry for it.

Radish "-corrected" logs often keep the raw odometry for only a few steps (orebro: 17 of 236), and their
scans are keyframes 1–3 m apart, so a step is found by a wide correlative search. In a corridor that search is
ambiguous: peaks 2–3 m apart along it score within a few percent of each other. The prior is the constant
velocity model (the previous step repeated), and the search score is penalised by a weak quadratic in the
distance from it (score − w_xy·‖Δt‖² − w_yaw·Δθ²): at 0.01 per m² a peak 2.5 m from the prediction loses
0.06 of mean hit likelihood, enough to break a near tie, too little to override a clearly better match (a
turn after a straight run, where the prediction is wrong, still matches).
"""

from __future__ import annotations

import math

from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between
from slam import se2


class MotionPriorConfig(StrictModel):
    """Search of a step without usable odometry (or whose normal-window match failed)."""

    constant_velocity: bool = Field(True, description="seed the wide window with the previous step "
                                    "(False: with no motion)")
    weight_xy: float = Field(0.01, ge=0, description="score penalty per m² away from the prediction")
    weight_yaw: float = Field(0.01, ge=0, description="score penalty per rad² away from the prediction")
    fill_ratio: float = Field(4.0, ge=0, description="local map: fill the gaps between consecutive returns "
                              "on one surface (gap ≤ this × r·Δφ; 0: off), see slam.surface_fill")
    fill_max_gap: float = Field(1.0, gt=0, description="… and ≤ this, m")
    sigma_xy: float = Field(1.0, gt=0, description="σ of the edge when such a step finds no match (the "
                            "prediction alone): loose, so loop closures can move it, m")
    sigma_yaw: float = Field(0.5, gt=0, description="rad")


def predicted_step(poses: list[se2.PoseTuple], constant_velocity: bool = True) -> se2.PoseTuple:
    """The step expected next: the last estimated step (constant velocity), or none."""
    if not constant_velocity or len(poses) < 2:
        return (0.0, 0.0, 0.0)
    return se2_between(poses[-2], poses[-1])


def at_window_edge(pose: se2.PoseTuple, guess: se2.PoseTuple, window_xy: float, window_yaw: float,
                   margin_xy: float, margin_yaw: float) -> bool:
    """True if a search result lies on its window's boundary: not a peak of the score surface but where the
    window cut a slope off (measured on orebro: a 93° wrong turn at the edge of the ±85° window, then
    extrapolated by the constant-velocity prediction into two more)."""
    dx, dy = abs(pose[0] - guess[0]), abs(pose[1] - guess[1])
    dyaw = abs(math.remainder(pose[2] - guess[2], math.tau))
    return dx >= window_xy - margin_xy or dy >= window_xy - margin_xy or dyaw >= window_yaw - margin_yaw
