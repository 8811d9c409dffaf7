"""Smoothing stays collision-free; the timed trajectory never exceeds its limits; closed-form durations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.collision import FclWorld
from planning.costmap import LayeredCostmap
from planning.global_planners import get_planner
from planning.trajectory import smooth_path, time_parameterize
from planning.types import Trajectory
from sim.errors import FleetError
from sim.types import Pose2D
from tests.planning.worlds import clutter, two_rooms

V, A, W, ALPHA = 0.8, 1.0, 2.0, 4.0


def _check_limits(tr: Trajectory) -> None:
    dt = np.diff(tr.t)
    assert (dt > 0).all()
    assert (tr.v <= V + 1e-9).all() and (tr.v >= -1e-12).all()
    assert (np.abs(tr.w) <= W + 1e-9).all()
    # between samples the speed changes at constant acceleration: Δv/Δt is that acceleration
    assert (np.abs(np.diff(tr.v) / dt) <= A * (1 + 1e-9)).all()
    # turns in place (v = 0 at both ends) obey the angular acceleration limit
    turning = (tr.v[:-1] == 0) & (tr.v[1:] == 0)
    assert (np.abs(np.diff(tr.w) / dt)[turning] <= ALPHA * (1 + 1e-9)).all()
    assert tr.v[0] == 0 and tr.v[-1] == 0


def test_straight_line_duration_is_the_trapezoid_closed_form() -> None:
    length = 5.0
    tr = time_parameterize(np.array([[0.0, 0.0], [length, 0.0]]), max_v=V, max_a=A, ds=0.05)
    _check_limits(tr)
    # samples every ds: where the speed reaches V inside a segment, that segment is timed at constant
    # acceleration, which costs at most ds / V at each of the two switching points
    exact = length / V + V / A
    assert exact - 1e-9 <= tr.duration <= exact + 2 * 0.05 / V
    assert tr.length == pytest.approx(length)
    assert tr.v.max() == pytest.approx(V)
    short = time_parameterize(np.array([[0.0, 0.0], [0.4, 0.0]]), max_v=V, max_a=A, ds=0.05)
    assert short.duration == pytest.approx(2 * math.sqrt(0.4 / A), rel=1e-9)  # triangle: never reaches V


def test_turns_in_place_at_sharp_corners_and_to_the_goal_yaw() -> None:
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    tr = time_parameterize(path, max_v=V, max_a=A, max_w=W, max_alpha=ALPHA, goal_yaw=math.pi)
    _check_limits(tr)
    at_corner = np.hypot(tr.x - 1.0, tr.y) < 1e-12
    assert tr.v[at_corner].max() == 0.0
    assert tr.yaw[-1] == pytest.approx(math.pi) or tr.yaw[-1] == pytest.approx(-math.pi)
    # π/2 at the corner and π/2 at the goal, each a trapezoid in w since √(θ·α) = 2.5 > W
    turn = (math.pi / 2) / W + W / ALPHA
    straight = 2 * (1.0 / V + V / A)
    exact = straight + 2 * turn
    assert exact - 1e-9 <= tr.duration <= exact + 4 * 0.05 / V


def test_curvature_limits_speed_on_arcs() -> None:
    a = np.linspace(0, math.pi, 200)
    r = 0.5
    arc = np.column_stack([r * np.cos(a), r * np.sin(a)])
    tr = time_parameterize(arc, max_v=V, max_a=A, max_w=1.0, max_lat_acc=0.5, ds=0.02)
    _check_limits(tr)
    # v ≤ min(w_max·r, √(a_lat·r)) = min(0.5, 0.5) on the arc
    assert tr.v.max() <= 0.5 + 1e-3
    assert tr.v.max() > 0.45


def test_planned_smoothed_timed_path_stays_clear_and_within_limits() -> None:
    for world, s, g in ((two_rooms(), Pose2D(1, 1), Pose2D(9, 1)), (clutter(seed=4), Pose2D(1, 1), Pose2D(11, 11))):
        cm = LayeredCostmap.from_world(world, robot_radius=0.3, resolution=0.05)
        plan = get_planner("theta_star").plan(s, g, cm)
        smooth = smooth_path(plan.path, cm, max_radius=0.6)
        assert FclWorld(world).path_min_distance(smooth, 0.3, step=0.01) > 0
        assert np.allclose(smooth[0], plan.path[0]) and np.allclose(smooth[-1], plan.path[-1])
        tr = time_parameterize(smooth, max_v=V, max_a=A, max_w=W, max_alpha=ALPHA, max_lat_acc=1.0)
        _check_limits(tr)
        assert tr.length == pytest.approx(float(np.hypot(*np.diff(smooth, axis=0).T).sum()), rel=1e-9)
        x, y, _, v, _ = tr.sample(tr.duration / 2)
        assert cm.is_free(x, y) and 0 <= v <= V


def test_bad_limits_are_rejected() -> None:
    with pytest.raises(FleetError):
        time_parameterize(np.array([[0.0, 0.0], [1.0, 0.0]]), max_v=0.0, max_a=1.0)
    with pytest.raises(FleetError):
        time_parameterize(np.array([[0.0, 0.0], [0.0, 0.0]]), max_v=1.0, max_a=1.0)
