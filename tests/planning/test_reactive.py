"""The reactive layer: stops a robot in front of a wall at the safety distance, slows by a closed form,
ignores what is beside its path, and reports `blocked` after staying stopped."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.nav_types import SafetyState
from planning.reactive import ReactiveConfig, ReactiveLayer, make_reactive
from sim.drive import integrate_unicycle
from sim.robot_spec import RobotSpec
from sim.types import LidarScan

SPEC = RobotSpec()  # footprint 0.5 × 0.45 m (chassis plus wheels): front edge 0.25 m ahead of base_link
FRONT = 0.25
BEAMS = 720


def scan_of_segments(segments, x=0.0, y=0.0, yaw=0.0) -> LidarScan:
    """Exact ranges from a lidar at (x, y, yaw) to line segments [(ax, ay, bx, by)], as the sim would return."""
    a = -math.pi + 2 * math.pi / BEAMS * np.arange(BEAMS)
    d = np.column_stack([np.cos(a + yaw), np.sin(a + yaw)])
    ranges = np.full(BEAMS, np.inf)
    for ax, ay, bx, by in segments:
        e = np.array([bx - ax, by - ay])
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((ax - x) * e[1] - (ay - y) * e[0]) / den  # along the beam
            u = ((ax - x) * d[:, 1] - (ay - y) * d[:, 0]) / den  # along the segment
        ok = np.isfinite(t) & (t > 0.1) & (u >= 0) & (u <= 1) & (t <= 10.0)
        ranges[ok] = np.minimum(ranges[ok], t[ok])
    return LidarScan("r", 0.0, -math.pi, 2 * math.pi / BEAMS, 0.1, 10.0, ranges)


def layer(**kw) -> ReactiveLayer:
    return make_reactive(ReactiveConfig(**kw), footprint=SPEC.footprint, max_a=SPEC.limits.max_linear_accel)


@pytest.mark.parametrize("safety", [0.1, 0.3])
def test_robot_stops_at_the_safety_distance_before_a_wall(safety):
    wall_x = 4.0
    wall = [(wall_x, -3.0, wall_x, 3.0)]
    react = layer(safety_distance=safety, slowdown_distance=0.8)
    x, v, dt, a = 0.0, 0.0, 0.02, SPEC.limits.max_linear_accel
    for k in range(1000):
        out = react.filter(0.8, 0.0, scan_of_segments(wall, x=x), now=k * dt)
        v += float(np.clip(out.v - v, -a * dt, a * dt))  # the robot's acceleration limit
        x = float(integrate_unicycle(np.array([x]), np.zeros(1), np.zeros(1), np.array([v]), np.zeros(1), dt)[0][0])
    gap = wall_x - (x + FRONT)
    assert v == 0.0 and out.state is SafetyState.STOPPED
    assert safety - 0.005 <= gap <= safety + 0.03


def test_speed_inside_the_slowdown_zone_follows_the_closed_form():
    s, sd, m, brake = 0.2, 1.0, 0.3, 0.8
    react = layer(safety_distance=s, slowdown_distance=sd, min_slow_scale=m, brake_fraction=brake, step=0.005)
    for d in (0.35, 0.6, 0.9):
        out = react.filter(0.8, 0.0, scan_of_segments([(FRONT + d, -2.0, FRONT + d, 2.0)]), now=0.0)
        dc = out.distance_to_collision
        expected = min(0.8 * (m + (1 - m) * (dc - s) / (sd - s)),
                       math.sqrt(2 * brake * SPEC.limits.max_linear_accel * (dc - s)))
        assert out.state is SafetyState.SLOWING
        assert d - 0.006 <= out.distance_to_collision <= d  # conservative by at most one sweep step
        assert out.v == pytest.approx(expected, abs=0.01)


def test_walls_beside_the_path_do_not_slow_the_robot():
    corridor = [(-5.0, 0.45, 5.0, 0.45), (-5.0, -0.45, 5.0, -0.45)]  # 0.9 m corridor, robot 0.45 m wide
    out = layer().filter(0.8, 0.0, scan_of_segments(corridor), now=0.0)
    assert out.state is SafetyState.CLEAR and out.v == 0.8
    # but turning into the wall is not allowed
    turn = layer().filter(0.3, 1.5, scan_of_segments(corridor), now=0.0)
    assert turn.state is not SafetyState.CLEAR and turn.v < 0.3
    assert turn.w == pytest.approx(1.5 * turn.v / 0.3)  # ω scaled with v: same arc


def test_backing_up_checks_behind():
    wall_behind = [(-FRONT - 0.1, -2.0, -FRONT - 0.1, 2.0)]
    assert layer(safety_distance=0.15).filter(-0.2, 0.0, scan_of_segments(wall_behind), now=0.0).v == 0.0
    assert layer(safety_distance=0.15).filter(0.2, 0.0, scan_of_segments(wall_behind), now=0.0).v == 0.2


def test_turning_in_place_is_stopped_by_a_post_inside_the_swept_circle():
    post = [(0.2, 0.25, 0.2, 0.26)]  # outside the footprint box (|y| ≤ 0.225) but within its 0.336 m radius
    assert layer().filter(0.0, 1.0, scan_of_segments(post), now=0.0).state is SafetyState.STOPPED
    far_post = [(0.2, 0.6, 0.2, 0.62)]
    assert layer().filter(0.0, 1.0, scan_of_segments(far_post), now=0.0).state is SafetyState.CLEAR


def test_blocked_after_staying_stopped_for_the_timeout():
    react = layer(safety_distance=0.2, blocked_timeout_s=1.0)
    wall = scan_of_segments([(FRONT + 0.1, -1.0, FRONT + 0.1, 1.0)])
    flags = [react.filter(0.5, 0.0, wall, now=t).blocked for t in (0.0, 0.5, 0.99, 1.0, 1.5)]
    assert flags == [False, False, False, True, True]
    assert not react.filter(0.0, 0.0, wall, now=2.0).blocked  # no motion asked: not stopped by the layer


def test_a_blocked_arc_still_lets_the_robot_turn_on_the_spot():
    react = layer(safety_distance=0.2, blocked_timeout_s=0.5)
    wall = scan_of_segments([(FRONT + 0.1, -1.0, FRONT + 0.1, 1.0)])  # 0.1 m ahead: a wall the spin cannot reach
    outs = [react.filter(0.5, 1.0, wall, now=t) for t in (0.0, 1.0)]
    assert all(o.v == 0.0 and o.w == 1.0 and o.state is SafetyState.STOPPED for o in outs)
    assert not outs[-1].blocked  # turning is progress: no replan request
