"""Regulated pure pursuit against closed forms: ω = v/R on a circle, v·R/R_min on tight arcs."""

from __future__ import annotations

import math

import numpy as np

from planning.controllers import PathReference, make_controller
from sim.drive import integrate_unicycle
from sim.robot_spec import LimitsSpec
from sim.types import Pose2D

LIMITS = LimitsSpec()


def circle_ref(radius: float, speed: float) -> PathReference:
    t = np.linspace(0.0, 3 * 2 * math.pi, 4000)
    return PathReference.from_points(np.column_stack([radius * np.cos(t), radius * np.sin(t)]), max_v=speed,
                                     max_a=1.0, max_lat_a=10.0, stop_at_end=False)


def drive(ctrl, ref, pose, seconds, dt=0.05):
    v = w = 0.0
    poses, cmds = [], []
    for k in range(round(seconds / dt)):
        out = ctrl.compute(pose, (v, w), ref, now=k * dt)
        v += float(np.clip(out.v - v, -1.5 * dt, 1.5 * dt))
        w += float(np.clip(out.w - w, -4.0 * dt, 4.0 * dt))
        x, y, th = (float(a[0]) for a in integrate_unicycle(
            np.array([pose.x]), np.array([pose.y]), np.array([pose.yaw]), np.array([v]), np.array([w]), dt))
        pose = Pose2D(x, y, th)
        poses.append(pose)
        cmds.append((out.v, out.w))
    return poses, np.array(cmds)


def test_pure_pursuit_converges_onto_a_line():
    ref = PathReference.from_points(np.array([[0.0, 0.0], [30.0, 0.0]]), max_v=0.5, max_a=1.0)
    ctrl = make_controller({"type": "pure_pursuit", "desired_linear_vel": 0.5}, LIMITS)
    poses, cmds = drive(ctrl, ref, Pose2D(0.0, 0.5, 0.0), seconds=15.0)
    assert max(abs(p.y) for p in poses[-40:]) < 0.01
    assert np.allclose(cmds[-40:, 0], 0.5, atol=1e-6)


def test_on_a_circle_the_pursuit_arc_is_the_circle():
    # the lookahead point on a circle of radius R, seen from a point on it, gives curvature exactly 1/R
    radius, speed = 2.0, 0.5
    ctrl = make_controller({"type": "pure_pursuit", "desired_linear_vel": speed}, LIMITS)
    poses, cmds = drive(ctrl, circle_ref(radius, speed), Pose2D(radius, 0.0, math.pi / 2), seconds=20.0)
    r = np.array([math.hypot(p.x, p.y) for p in poses[-100:]])
    assert np.abs(r - radius).max() < 0.02
    assert np.allclose(cmds[-100:, 0], speed, atol=1e-6)
    assert np.allclose(cmds[-100:, 1], speed / radius, atol=0.01)


def test_tight_arcs_are_driven_slower_by_radius_over_min_radius():
    radius, v_des, r_min = 0.5, 0.5, 0.9
    ctrl = make_controller({"type": "pure_pursuit", "desired_linear_vel": v_des, "regulated_min_radius": r_min,
                            "regulated_min_speed": 0.0}, LIMITS)
    _, cmds = drive(ctrl, circle_ref(radius, v_des), Pose2D(radius, 0.0, math.pi / 2), seconds=15.0)
    assert np.allclose(cmds[-60:, 0], v_des * radius / r_min, atol=0.01)


def test_a_path_behind_the_robot_makes_it_rotate_in_place():
    ref = PathReference.from_points(np.array([[0.0, 0.0], [-5.0, 0.0]]), max_v=0.5, max_a=1.0)
    ctrl = make_controller({"type": "pure_pursuit", "rotate_to_heading_vel": 1.0}, LIMITS)
    out = ctrl.compute(Pose2D(0.0, 0.0, 0.0), (0.0, 1.0), ref, now=0.0)
    assert out.v == 0.0 and abs(out.w) == 1.0
