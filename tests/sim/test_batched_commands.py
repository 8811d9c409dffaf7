"""World.set_cmd_vels (many robots in one call) does exactly what one set_cmd_vel per robot does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim import ErrorCode, FleetError, Pose2D, World


def fleet(n: int = 12) -> World:
    w = World(physics_hz=10, seed=1)
    for k in range(n):
        w.spawn_robot(f"r{k}", Pose2D(3.0 * (k % 4), 3.0 * (k // 4), 0.3 * k))
    return w


def test_batched_commands_clamp_and_drive_exactly_like_one_call_per_robot():
    rng = np.random.default_rng(3)
    with fleet() as one, fleet() as many:
        names = one.robot_names()
        limits = one.robot_spec(names[0]).limits
        for _ in range(15):
            v, w = rng.uniform(-2, 2, len(names)), rng.uniform(-4, 4, len(names))  # some beyond the limits
            pick = rng.permutation(len(names))[:8]
            results = [one.set_cmd_vel(names[i], float(v[i]), float(w[i])) for i in pick]
            if rng.random() < 0.5:
                clamped = many.set_cmd_vels([names[i] for i in pick], v[pick], w[pick])
            else:
                clamped = many.set_cmd_vels(pick, v[pick], w[pick])  # rows of robot_names()
            assert clamped.tolist() == [r.clamped for r in results]
            for r in results:
                assert abs(r.applied_v) <= limits.max_linear and abs(r.applied_w) <= limits.max_angular
            for col in ("cmd_v", "cmd_w"):
                assert np.array_equal(one.table.f[col], many.table.f[col])
            one.step(2)
            many.step(2)
        for col in ("x", "y", "yaw", "v", "w"):
            assert np.array_equal(one.table.f[col], many.table.f[col])


def test_one_twist_for_all():
    with fleet(4) as w:
        clamped = w.set_cmd_vels(w.robot_names(), 0.5, -3.0)
        max_w = w.robot_spec("r0").limits.max_angular
        assert clamped.tolist() == [True] * 4
        assert w.table.f["cmd_v"].tolist() == [0.5] * 4 and w.table.f["cmd_w"].tolist() == [-max_w] * 4


@pytest.mark.parametrize(("robots", "v", "w", "code", "words"), [
    (["r0", "nobody"], [0.1, 0.1], [0.0, 0.0], ErrorCode.UNKNOWN_ROBOT, ["nobody", "r0, r1"]),
    (np.array([0, 9]), [0.1, 0.1], [0.0, 0.0], ErrorCode.INVALID_ARGUMENT, ["row 9", "0…3"]),
    (["r0", "r1"], [0.1, math.nan], [0.0, 0.0], ErrorCode.INVALID_ARGUMENT, ["'r1'", "finite"]),
    (["r0", "r1"], [0.1, 0.2, 0.3], [0.0, 0.0], ErrorCode.INVALID_ARGUMENT, ["2 robots", "3 v"]),
])
def test_a_bad_entry_is_refused_and_changes_nothing(robots, v, w, code, words):
    with fleet(4) as world:
        world.set_cmd_vels(world.robot_names(), 0.3, 0.1)
        before = world.table.f["cmd_v"].copy(), world.table.f["cmd_w"].copy()
        with pytest.raises(FleetError) as e:
            world.set_cmd_vels(robots, v, w)
        assert e.value.code is code
        text = f"{e.value.message} {e.value.hint}"
        assert all(word in text for word in words), text
        assert np.array_equal(world.table.f["cmd_v"], before[0]) and np.array_equal(world.table.f["cmd_w"], before[1])
