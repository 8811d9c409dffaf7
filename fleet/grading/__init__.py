"""Grading: course artefact checks (world and robot rubrics) and navigation challenges (BARN score, reports,
leaderboard, generated arenas)."""

from fleet.grading.challenge import Challenge, ResolvedChallenge, load_challenge, resolve
from fleet.grading.course_nav import navigation_rubric
from fleet.grading.course_robot import check_robot, grade_robot
from fleet.grading.course_world import check_world, grade_world
from fleet.grading.rubric import RubricItem, RubricReport
from fleet.grading.runner import run_challenge
from fleet.grading.score import barn_score, optimal_path, score_run, summarize
from fleet.grading.types import ChallengeReport, Outcome, RunResult, RunScore

__all__ = [
    "Challenge",
    "ChallengeReport",
    "Outcome",
    "ResolvedChallenge",
    "RubricItem",
    "RubricReport",
    "RunResult",
    "RunScore",
    "barn_score",
    "check_robot",
    "check_world",
    "grade_robot",
    "grade_world",
    "load_challenge",
    "navigation_rubric",
    "optimal_path",
    "resolve",
    "run_challenge",
    "score_run",
    "summarize",
]
