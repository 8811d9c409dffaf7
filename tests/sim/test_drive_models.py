"""Drive models against closed forms: a constant (v, ω) traces a circle of radius v/ω; limits hold."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import ErrorCode, FleetError, Pose2D, World


def fit_circle(xy: np.ndarray) -> tuple[float, float, float]:
    a = np.column_stack([2 * xy[:, 0], 2 * xy[:, 1], np.ones(len(xy))])
    cx, cy, c = np.linalg.lstsq(a, (xy**2).sum(1), rcond=None)[0]
    return float(cx), float(cy), math.sqrt(c + cx * cx + cy * cy)


@pytest.mark.parametrize(("fidelity", "hz", "tol"), [("kinematic", 100, 1e-6), ("dynamic", 240, 0.03)])
@pytest.mark.parametrize(("v", "w"), [(0.5, 0.5), (0.4, -0.8)])
def test_constant_twist_traces_circle_of_radius_v_over_w(fidelity: str, hz: int, tol: float, v: float, w: float):
    with World(physics_hz=hz, seed=0, fidelity=fidelity) as world:  # type: ignore[arg-type]
        world.spawn_robot("r", Pose2D(0, 0, 0))
        world.set_cmd_vel("r", v, w)
        world.run_for(2.0)  # past the acceleration ramp
        pts, yaws = [], []
        for _ in range(60):
            world.run_for(0.1)
            pose = world.robot_pose("r")
            pts.append((pose.x, pose.y))
            yaws.append(pose.yaw)
        _, _, radius = fit_circle(np.array(pts))
        assert radius == pytest.approx(abs(v / w), rel=tol)
        mean_rate = (np.unwrap(yaws)[-1] - yaws[0]) / 5.9
        assert mean_rate == pytest.approx(w, rel=max(tol, 0.08))  # wheels slip a little under physics


def test_commands_past_the_limits_are_clamped_and_reported(world: World):
    world.spawn_robot("r", Pose2D())
    spec = world.robot_spec("r")
    res = world.set_cmd_vel("r", 5.0, -9.0)
    assert res.clamped
    assert res.applied_v == spec.limits.max_linear
    assert res.applied_w == -spec.limits.max_angular
    assert "linear" in res.reason and "angular" in res.reason
    ok = world.set_cmd_vel("r", 0.2, 0.1)
    assert not ok.clamped and ok.reason == ""


@pytest.mark.parametrize("fidelity", ["kinematic", "dynamic"])
def test_acceleration_limit_ramps_velocity(fidelity: str):
    with World(physics_hz=200, seed=0, fidelity=fidelity) as world:  # type: ignore[arg-type]
        world.spawn_robot("r", Pose2D())
        a_max = world.robot_spec("r").limits.max_linear_accel
        world.set_cmd_vel("r", 1.0, 0.0)
        world.run_for(0.2)
        v, _ = world.robot_twist("r")
        assert v == pytest.approx(a_max * 0.2, rel=0.06)  # ramp, not a jump to 1.0 m/s


def test_non_finite_commands_and_poses_are_rejected(world: World):
    world.spawn_robot("r", Pose2D())
    with pytest.raises(FleetError) as e:
        world.set_cmd_vel("r", math.nan, 0.0)
    assert e.value.code is ErrorCode.INVALID_ARGUMENT
    with pytest.raises(FleetError):
        Pose2D(math.inf, 0, 0)
    world.step(3)  # the world keeps running
    assert world.step_count == 3


def test_unknown_robot_lists_the_known_ones(world: World):
    world.spawn_robot("alpha", Pose2D())
    world.spawn_robot("beta", Pose2D(2, 0, 0))
    with pytest.raises(FleetError) as e:
        world.robot_pose("gamma")
    assert e.value.code is ErrorCode.UNKNOWN_ROBOT
    assert "alpha" in e.value.hint and "beta" in e.value.hint
