"""Both MPCs converge onto closed-form references: a straight line and a circle (v, ω = v/R)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.controllers import OsqpMpc, PathReference, make_controller
from planning.costmap import LayeredCostmap
from planning.grid import OccupancyGrid
from sim.drive import integrate_unicycle
from sim.robot_spec import LimitsSpec
from sim.types import Pose2D

LIMITS = LimitsSpec()  # 1 m/s, 2 rad/s, 1.5 m/s², 4 rad/s²
MPCS = ["mpc_osqp", "mpc_casadi"]


def drive(controller, ref, pose, seconds, dt=0.05, costmap=None):
    """Accel-limited exact unicycle (the sim's kinematic model); returns poses, commands, outputs."""
    v = w = 0.0
    poses, cmds, outs = [], [], []
    for k in range(round(seconds / dt)):
        out = controller.compute(pose, (v, w), ref, now=k * dt, costmap=costmap)
        v += float(np.clip(out.v - v, -LIMITS.max_linear_accel * dt, LIMITS.max_linear_accel * dt))
        w += float(np.clip(out.w - w, -LIMITS.max_angular_accel * dt, LIMITS.max_angular_accel * dt))
        x, y, th = (float(a[0]) for a in integrate_unicycle(
            np.array([pose.x]), np.array([pose.y]), np.array([pose.yaw]), np.array([v]), np.array([w]), dt))
        pose = Pose2D(x, y, th)
        poses.append(pose)
        cmds.append((out.v, out.w))
        outs.append(out)
    return poses, np.array(cmds), outs


@pytest.mark.parametrize("kind", MPCS)
def test_mpc_converges_onto_a_straight_line(kind):
    ref = PathReference.from_points(np.array([[0.0, 0.0], [30.0, 0.0]]), max_v=0.5, max_a=1.0)
    ctrl = make_controller({"type": kind}, LIMITS)
    poses, cmds, outs = drive(ctrl, ref, Pose2D(0.0, 0.6, 0.4), seconds=15.0)
    tail = poses[-40:]  # the last 2 s
    assert max(abs(p.y) for p in tail) < 0.01  # on the line y = 0
    assert max(abs(p.yaw) for p in tail) < 0.01  # heading along +x
    assert np.allclose(cmds[-40:, 0], 0.5, atol=0.01)  # at the reference speed
    assert all(o.converged for o in outs)
    assert max(abs(p.y) for p in poses[:20]) > 0.5  # it did start well off the line
    # the robot's limits hold for every command: |v| ≤ 1, |ω| ≤ 2, |Δv| ≤ 1.5·dt, |Δω| ≤ 4·dt
    assert np.abs(cmds[:, 0]).max() <= 1.0 + 1e-9 and np.abs(cmds[:, 1]).max() <= 2.0 + 1e-9
    assert np.abs(np.diff(cmds[:, 0])).max() <= 1.5 * 0.05 + 1e-9
    assert np.abs(np.diff(cmds[:, 1])).max() <= 4.0 * 0.05 + 1e-9


@pytest.mark.parametrize("kind", MPCS)
def test_mpc_converges_onto_a_circle(kind):
    radius, speed = 2.0, 0.5
    t = np.linspace(0.0, 3 * 2 * math.pi, 3000)  # three laps, counter-clockwise, centre (0, 0)
    ref = PathReference.from_points(np.column_stack([radius * np.cos(t), radius * np.sin(t)]), max_v=speed,
                                    max_a=1.0, max_lat_a=1.0, stop_at_end=False)
    ctrl = make_controller({"type": kind}, LIMITS)
    poses, cmds, _ = drive(ctrl, ref, Pose2D(2.3, 0.0, math.pi / 2), seconds=20.0)
    tail = poses[-60:]
    r = np.array([math.hypot(p.x, p.y) for p in tail])
    assert np.abs(r - radius).max() < 0.02  # on the circle
    # constant twist on a circle: v = speed, ω = v / R
    assert np.allclose(cmds[-60:, 0], speed, atol=0.02)
    assert np.allclose(cmds[-60:, 1], speed / radius, atol=0.02)


@pytest.mark.parametrize("kind", MPCS)
def test_mpc_tracks_a_figure_eight_within_5cm(kind):
    s = np.linspace(0.0, 2 * math.pi, 2000)
    ref = PathReference.from_points(np.column_stack([2.0 * np.sin(s), 2.0 * np.sin(s) * np.cos(s)]),
                                    max_v=0.5, max_a=1.0, max_lat_a=10.0)
    ctrl = make_controller({"type": kind}, LIMITS)
    _, _, outs = drive(ctrl, ref, Pose2D(0.0, 0.0, math.atan2(ref.y[1], ref.x[1])), seconds=27.0)
    e = np.array([o.cross_track for o in outs])
    assert math.sqrt(float(np.mean(e**2))) < 0.05
    assert ref.remaining(outs[-1].progress) < 0.05  # it went all the way round (the crossing did not confuse it)


def test_casadi_obstacle_penalty_keeps_clearance():
    # a straight reference passing 0.4 m from a wall segment the path itself ignores
    grid = OccupancyGrid.empty((-1.0, -2.0, 12.0, 2.0), 0.05)
    grid.data[int((0.4 + 2.0) / 0.05):int((0.6 + 2.0) / 0.05), int((4.0 + 1.0) / 0.05):int((6.0 + 1.0) / 0.05)] = 100
    costmap = LayeredCostmap(grid, robot_radius=0.3, padding=0.0)
    ref = PathReference.from_points(np.array([[0.0, 0.0], [10.0, 0.0]]), max_v=0.5, max_a=1.0)
    clearances = {}
    for weight in (0.0, 200.0):
        ctrl = make_controller({"type": "mpc_casadi", "obstacle_weight": weight, "obstacle_margin": 0.15}, LIMITS)
        poses, _, _ = drive(ctrl, ref, Pose2D(0.0, 0.0, 0.0), seconds=16.0, costmap=costmap)
        clearances[weight] = min(costmap.clearance(p.x, p.y) for p in poses)
    on_path = costmap.clearance(5.0, 0.0)  # ≈ 0.4 m: less than robot radius + margin = 0.45 m
    assert clearances[0.0] == pytest.approx(on_path, abs=0.02)  # without the penalty it follows the path
    assert clearances[200.0] > clearances[0.0] + 0.03  # with it, it keeps away from the wall


def test_ltv_qp_keeps_one_sparsity_pattern_and_matches_the_model():
    ctrl = make_controller({"type": "mpc_osqp"}, LIMITS)
    assert isinstance(ctrl, OsqpMpc)
    qp = ctrl.qp
    pattern = (qp.A.indices.copy(), qp.A.indptr.copy(), qp.P.indices.copy(), qp.P.indptr.copy())
    n = qp.n
    for yaw0, v in ((0.0, 0.0), (math.pi / 2, 0.7)):  # sin θ = 0 and v = 0 zero out entries: still stored
        x_ref = np.column_stack([np.arange(n + 1) * 0.1 * v * math.cos(yaw0),
                                 np.arange(n + 1) * 0.1 * v * math.sin(yaw0), np.full(n + 1, yaw0)])
        u_ref = np.column_stack([np.full(n, v), np.zeros(n)])
        qp.fill(x_ref, u_ref, x_ref[0] + [0.0, 0.1, 0.0], np.zeros(2))
        assert all(np.array_equal(a, b) for a, b in zip(pattern, (qp.A.indices, qp.A.indptr, qp.P.indices,
                                                                  qp.P.indptr), strict=True))
        # the reference is an exact solution of the linearised dynamics rows (zero residual on a line)
        z = np.concatenate([np.zeros(3 * (n + 1)), np.zeros(2 * n)])
        dyn = (qp.A @ z)[3:3 * (n + 1)]
        assert np.allclose(dyn, qp.l[3:3 * (n + 1)]) and np.allclose(qp.l[3:3 * (n + 1)], 0.0)
