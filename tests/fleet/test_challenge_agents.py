"""Grading contestants that are separate processes over the Zenoh API in lock-step: the reference goal seeker,
and agents that drive into a wall, crash, hang or never join. Every run ends with a graded outcome."""

from __future__ import annotations

import math
import sys

import pytest

from fleet.grading import Outcome, load_challenge, run_challenge
from fleet.paths import ROOT

pytest.importorskip("zenoh")

SEEKER = (f"python {ROOT / 'examples' / 'goal_seeker.py'} --connect {{connect}} --robot {{robot}} "
          "--goal {goal_x} {goal_y} --lockstep --agent-id seeker")
MISBEHAVE = f"{sys.executable} {ROOT / 'tests' / 'fleet' / 'challenge_agents.py'}"
WALL_GAP = 6.0 - 5.25  # the arena's west wall (inner face x = −6) to the chassis front at x = −5 + 0.25


@pytest.fixture
def facing_wall(tmp_path):
    """The course arena, the robot at (−5, −5) facing the west wall; short limits."""
    path = tmp_path / "facing_wall.yaml"
    path.write_text(f"""
name: facing_wall
world: robot_arena
start: {{x: -5.0, y: -5.0, yaw: {math.pi!r}}}
goal: goal_marker
time_limit: 8.0
agent: {{startup_timeout_s: 20.0, tick_timeout_s: 1.0, wall_limit_s: 60.0}}
""", encoding="utf-8")
    return load_challenge(path)


def test_reference_goal_seeker_completes_an_arena_with_the_exact_score(tmp_path):
    report = run_challenge("cluttered_1", agent=SEEKER, runs=1, out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.SUCCEEDED, f"{run.reason}\n{run.agent_log}"
    s = run.score
    t_opt = 8 * math.sqrt(2) / 1.0  # the free diagonal (−4, −4) → (4, 4) at the diffbot's max speed
    assert s.t_opt == pytest.approx(t_opt, abs=0.02)
    assert s.score == pytest.approx(s.t_opt / min(max(s.time, 2 * s.t_opt), 8 * s.t_opt))
    assert 0.125 <= s.score <= 0.5
    assert s.time == pytest.approx(run.trajectory[-1, 0])  # the run ended on the tick the goal was reached
    assert math.hypot(run.trajectory[-1, 1] - 4.0, run.trajectory[-1, 2] - 4.0) <= 0.5
    assert s.collisions == 0
    assert report.rubric.earned == report.rubric.total


def test_reference_goal_seeker_completes_the_course_arena_maze(tmp_path):
    """The course's own challenge: spawn_start → goal_marker through the barriers, over Zenoh in lock-step;
    with `map_source: prior` chosen explicitly, so the seeker may plan its route over the world's map."""
    known = load_challenge("arena_course").model_copy(update={"map_source": "prior"})
    report = run_challenge(known, agent=SEEKER, runs=1, out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.SUCCEEDED, f"{run.reason}\n{run.agent_log}"
    s = run.score
    assert s.collisions == 0
    assert s.t_opt > math.hypot(10, 10)  # the maze is longer than the straight line
    assert s.score == pytest.approx(s.t_opt / min(max(s.time, 2 * s.t_opt), 8 * s.t_opt))
    assert 0.125 <= s.score <= 0.5
    assert math.hypot(run.trajectory[-1, 1] - 5.0, run.trajectory[-1, 2] - 5.0) <= 0.5


def test_under_the_default_sensors_rule_the_graded_agent_is_refused_the_map(facing_wall, tmp_path):
    """The seeker asks for the occupancy map over Zenoh; a graded run on `sensors` (the default) refuses it
    with the rule's name, and the seeker falls back to seeking the goal on its scans."""
    assert facing_wall.map_source == "sensors"
    report = run_challenge(facing_wall, agent=SEEKER, runs=1, out_dir=tmp_path)
    log = report.runs[0].agent_log
    assert "no route (the world's occupancy map is withheld: challenge facing_wall" in log, log
    assert "map_source: sensors" in log


def test_driving_into_a_wall_is_a_collision_at_the_closed_form_time(facing_wall, tmp_path):
    report = run_challenge(facing_wall, agent=f"{MISBEHAVE} wall", out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.COLLISION, run.reason
    assert run.score.score == 0.0 and run.score.collisions == 1
    # 0.5 m/s reached at 1.5 m/s² after 1/3 s (1/12 m), then the rest of the gap at 0.5 m/s
    expected = 1 / 3 + (WALL_GAP - 1 / 12) / 0.5
    assert run.score.first_collision_time == pytest.approx(expected, abs=0.1)
    assert "wall_west" in run.reason
    assert report.rubric.failed_keys() == ["reaches_goal", "avoids_obstacles", "keeps_clear", "efficient"]


def test_a_crashing_agent_is_a_failure_with_its_exception(facing_wall, tmp_path):
    report = run_challenge(facing_wall, agent=f"{MISBEHAVE} crash", out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.AGENT_CRASHED
    assert "RuntimeError: controller blew up on purpose" in run.reason
    assert "exit code 1" in run.reason
    assert run.trajectory[-1, 0] < facing_wall.time_limit
    assert run.score.score == 0.0
    assert "autonomous" in report.rubric.failed_keys()


def test_a_hanging_agent_is_a_failure_within_the_tick_timeout(facing_wall, tmp_path):
    report = run_challenge(facing_wall, agent=f"{MISBEHAVE} hang", out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.AGENT_HUNG, run.reason
    assert "did not answer a lock-step tick within 1 s" in run.reason
    assert run.trajectory[-1, 0] < 1.0  # it answered 5 ticks (0.5 s of sim time), then went silent
    assert run.score.score == 0.0


def test_an_agent_that_never_joins_lock_step_is_a_failure(facing_wall, tmp_path):
    facing_wall.agent.startup_timeout_s = 3.0
    report = run_challenge(facing_wall, agent=f"{MISBEHAVE} idle", out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome is Outcome.AGENT_DID_NOT_CONNECT
    assert "within 3 s" in run.reason and len(run.trajectory) == 0
