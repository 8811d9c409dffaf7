"""The course's "Navigation Challenge" rubric (15 points), graded from a challenge's runs.

The course asks for a node that reads the lidar, avoids obstacles while seeking a goal, publishes velocity
commands and gets from the start to the goal. The thresholds below turn that into measurable items; each
item says what was measured, what was expected and the points (fleet.grading.rubric).
"""

from __future__ import annotations

from collections.abc import Sequence

from fleet.grading.rubric import RubricReport
from fleet.grading.types import Outcome, RunResult

MIN_SUCCESS_RATE = 0.8  # "robot should navigate from start to goal" on (nearly) every run
MIN_MARGIN = 0.05  # m: the footprint never came closer to an obstacle than this (no scraping past corners)
MIN_MEAN_SCORE = 0.25  # BARN: 0.25 = reaching the goal in 4·T_opt on average
AGENT_FAULTS = (Outcome.AGENT_CRASHED, Outcome.AGENT_HUNG, Outcome.AGENT_DID_NOT_CONNECT, Outcome.WALL_TIMEOUT)


def navigation_rubric(runs: Sequence[RunResult], source: str, safety_distance: float) -> RubricReport:
    rep = RubricReport("Navigation Challenge (navigation_controller.py)", source)
    n = len(runs)
    faults = [r for r in runs if r.outcome in AGENT_FAULTS]
    ok = sum(r.score.success for r in runs)
    hits = sum(r.score.collisions for r in runs)
    margin = min((r.score.min_clearance for r in runs), default=0.0)
    mean_score = sum(r.score.score for r in runs) / n if n else 0.0
    rep.add("autonomous", "the controller runs autonomously to the end of every run", 3, not faults,
            ", ".join(f"run {r.run}: {r.outcome.value}" for r in faults) or f"{n}/{n} runs without a fault",
            "no crash, hang or missed connection")
    rep.add("reaches_goal", "navigates from the start to the goal", 5, n > 0 and ok / n >= MIN_SUCCESS_RATE,
            f"{ok}/{n} runs reached the goal", f"≥ {MIN_SUCCESS_RATE:.0%} of runs")
    rep.add("avoids_obstacles", "obstacle avoidance working (no collisions)", 4, hits == 0,
            f"{hits} collision(s)", "0")
    danger = sum(r.score.time_in_danger for r in runs)
    rep.add("keeps_clear", "keeps a margin from obstacles (minimum clearance of the footprint)", 1,
            margin >= MIN_MARGIN, f"{margin:.3f} m ({danger:.1f} s closer than {safety_distance:g} m)",
            f"≥ {MIN_MARGIN} m")
    rep.add("efficient", "reaches the goal efficiently (mean BARN score)", 2, mean_score >= MIN_MEAN_SCORE,
            f"{mean_score:.3f}", f"≥ {MIN_MEAN_SCORE} (goal within 4·T_opt)")
    return rep
