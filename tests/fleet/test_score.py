"""The BARN score and its breakdown, against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fleet.grading import Outcome, RunResult, barn_score, optimal_path, score_run, summarize
from fleet.grading.score import clearances
from planning import FclWorld
from sim.sdf_primitives import box
from sim.types import Pose2D, WorldDescription

FOOTPRINT = [(0.25, -0.225), (-0.25, -0.225), (-0.25, 0.225), (0.25, 0.225)]  # the diffbot's chassis


def test_barn_score_closed_form_in_each_regime():
    t_opt = 10.0
    assert barn_score(True, 5.0, t_opt) == 0.5  # faster than 2·T_opt: clipped up to 2·T_opt
    assert barn_score(True, 20.0, t_opt) == 0.5
    assert barn_score(True, 40.0, t_opt) == pytest.approx(0.25)  # T_opt / T
    assert barn_score(True, 80.0, t_opt) == pytest.approx(0.125)
    assert barn_score(True, 500.0, t_opt) == pytest.approx(0.125)  # slower than 8·T_opt: clipped down
    assert barn_score(False, 30.0, t_opt) == 0.0


@given(t=st.floats(0.01, 1e4), t_opt=st.floats(0.01, 1e3))
def test_a_success_scores_between_an_eighth_and_a_half(t, t_opt):
    s = barn_score(True, t, t_opt)
    assert 0.125 - 1e-12 <= s <= 0.5 + 1e-12
    assert s == pytest.approx(t_opt / min(max(t, 2 * t_opt), 8 * t_opt))


def _one_box_world() -> WorldDescription:
    # a 1 m cube centred at (3, 0), 1 m tall: faces at x = 2.5 and 3.5, y = ±0.5
    return WorldDescription(name="one_box", models=(box("cube", (1.0, 1.0, 1.0), 3.0, 0.0, 0.0),))


def test_optimal_path_in_open_space_is_the_straight_line():
    plan = optimal_path(WorldDescription(name="open", models=(box("far", (0.5, 0.5, 1.0), 50.0, 50.0, 0.0),)),
                        Pose2D(-3.0, -4.0), Pose2D(3.0, 4.0), robot_radius=0.3)
    assert plan.length == pytest.approx(10.0, abs=1e-9)


def test_optimal_path_goes_around_an_obstacle_and_is_longer():
    desc = _one_box_world()
    plan = optimal_path(desc, Pose2D(1.0, 0.0), Pose2D(5.0, 0.0), robot_radius=0.3)
    # around a corner of the box grown by the radius: at least the two tangents to (2.5, ±0.8) and (3.5, ±0.8)
    lower = 2 * math.hypot(1.5, 0.8) + 1.0
    assert lower - 0.1 < plan.length < lower + 0.3


def test_clearance_is_the_exact_footprint_distance():
    fcl_world = FclWorld(_one_box_world())
    # facing the box, the chassis front (x + 0.25) is 2.5 − (x + 0.25) from the face at x = 2.5
    traj = np.array([[0.0, 1.0, 0.0, 0.0, 0.0, 0.0], [0.1, 2.0, 0.0, 0.0, 0.0, 0.0]])
    assert clearances(traj, fcl_world, FOOTPRINT) == pytest.approx([1.25, 0.25], abs=1e-6)


def _circle(v: float, w: float, seconds: float, dt: float = 0.1) -> np.ndarray:
    t = np.arange(0.0, seconds + 1e-9, dt)
    r = v / w
    yaw = w * t
    return np.column_stack([t, r * np.sin(yaw), r * (1 - np.cos(yaw)), yaw, np.full_like(t, v), np.full_like(t, w)])


def test_breakdown_of_a_constant_arc_matches_the_circle():
    v, w, secs = 0.5, 0.25, 8.0
    traj = _circle(v, w, secs)
    clear = np.where(traj[:, 0] < 3.0 - 1e-9, 0.1, 1.0)  # 30 samples of 0.1 s under 0.3 m
    s = score_run(traj, success=True, t=secs, optimal_length=3.0, v_max=1.0, collision_times=[],
                  clearance=clear, safety_distance=0.3, goal=Pose2D(float(traj[-1, 1]), float(traj[-1, 2])),
                  success_radius=0.5)
    chord = 2 * (v / w) * math.sin(w * 0.1 / 2)  # each 0.1 s step is a chord of the circle
    assert s.path_length == pytest.approx(80 * chord, rel=1e-9)
    assert s.curvature_mean == pytest.approx(w / v) and s.curvature_max == pytest.approx(w / v)
    assert s.accel_rms == 0.0 and s.jerk_rms == 0.0 and s.angular_jerk_rms == 0.0
    assert s.time_in_danger == pytest.approx(3.0)
    assert s.min_clearance == pytest.approx(0.1)
    assert s.t_opt == 3.0 and s.score == pytest.approx(3.0 / 8.0)  # T = 8 s is inside [2·T_opt, 8·T_opt]
    assert s.spl == pytest.approx((3.0 - 0.5) / s.path_length)  # to the success disc: L_opt − radius
    assert s.final_distance == pytest.approx(0.0)


def test_jerk_of_a_velocity_step():
    t = np.arange(0.0, 1.01, 0.1)
    v = np.where(t < 0.45, 0.0, 1.0)  # one step of 1 m/s between samples 4 and 5
    traj = np.column_stack([t, np.cumsum(v) * 0.1, np.zeros_like(t), np.zeros_like(t), v, np.zeros_like(t)])
    s = score_run(traj, success=False, t=1.0, optimal_length=5.0, v_max=1.0, collision_times=[2.0, 0.5],
                  clearance=np.ones(len(t)), safety_distance=0.3, goal=Pose2D(5.0, 0.0))
    # accel: one sample of 10 m/s² among 10; jerk: +100 and −100 m/s³ among 9
    assert s.accel_rms == pytest.approx(math.sqrt(100 / 10))
    assert s.jerk_rms == pytest.approx(math.sqrt(2 * 100**2 / 9))
    assert s.score == 0.0 and s.spl == 0.0
    assert s.collisions == 2 and s.first_collision_time == 0.5


def _result(k: int, success: bool, t: float, score: float) -> RunResult:
    traj = _circle(0.5, 0.25, 2.0)
    s = score_run(traj, success=success, t=t, optimal_length=10.0, v_max=1.0, collision_times=[],
                  clearance=np.ones(len(traj)), safety_distance=0.3, goal=Pose2D())
    assert s.score == pytest.approx(score)
    return RunResult(k, k, Outcome.SUCCEEDED if success else Outcome.TIMEOUT, "", s, traj)


def test_summary_over_runs_counts_failures_as_zero():
    runs = [_result(0, True, 20.0, 0.5), _result(1, True, 40.0, 0.25), _result(2, False, 99.0, 0.0)]
    s = summarize(runs)
    assert s["success_rate"] == pytest.approx(2 / 3)
    assert s["score"]["mean"] == pytest.approx(0.25)
    assert s["score"]["std"] == pytest.approx(0.25)  # sample std of (0.5, 0.25, 0)
    assert s["time"]["mean"] == pytest.approx(30.0)  # over the successes only
    assert s["outcomes"] == {"succeeded": 2, "timeout": 1}
