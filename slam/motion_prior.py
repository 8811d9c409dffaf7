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


def predicted_step(poses: list[se2.PoseTuple], constant_velocity: bool = True) -> se2.PoseTuple:
    """The step expected next: the last estimated step (constant velocity), or none."""
    if not constant_velocity or len(poses) < 2:
        return (0.0, 0.0, 0.0)
    return se2_between(poses[-2], poses[-1])
