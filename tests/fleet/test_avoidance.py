"""Multi-robot avoidance: ORCA's linear programs, head-on passes, a four-robot swap, the plugin registry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import ErrorCode, FleetConfig, FleetError, FleetService
from fleet.avoidance import AvoidanceConfig, NoAvoidance, OrcaFilter, register_avoidance, solve_lp
from sim import Pose2D

PP = {"controller": {"type": "pure_pursuit"}}


def test_lp_projects_the_preference_onto_the_allowed_half_planes():
    right_of_x1 = (1.0, 0.0, 0.0, 1.0)  # x ≤ 1 (allowed side to the left of the direction)
    below_y1 = (0.0, 1.0, -1.0, 0.0)  # y ≤ 1
    assert solve_lp([right_of_x1], 0, 10.0, (3.0, 2.0)) == pytest.approx((1.0, 2.0))
    assert solve_lp([right_of_x1, below_y1], 0, 10.0, (3.0, 3.0)) == pytest.approx((1.0, 1.0))
    assert solve_lp([right_of_x1], 0, 5.0, (30.0, 0.0)) == pytest.approx((1.0, 0.0))
    assert solve_lp([], 0, 5.0, (3.0, 4.0)) == pytest.approx((3.0, 4.0))
    assert np.hypot(*solve_lp([], 0, 2.0, (3.0, 4.0))) == pytest.approx(2.0)  # the speed disc


def test_lp_with_conflicting_constraints_splits_the_violation_unless_one_is_hard():
    x_le_1, x_ge_2 = (1.0, 0.0, 0.0, 1.0), (2.0, 0.0, 0.0, -1.0)
    assert solve_lp([x_le_1, x_ge_2], 0, 10.0, (3.0, 0.0))[0] == pytest.approx(1.5)
    assert solve_lp([x_le_1, x_ge_2], 1, 10.0, (3.0, 0.0))[0] == pytest.approx(1.0)  # the obstacle line holds


def _min_distance_run(svc: FleetService, starts: list[Pose2D], goals: list[Pose2D], limit_s: float):
    for k, p in enumerate(starts):
        svc.spawn_robot(f"r{k}", p)
    ids = [svc.navigate(f"r{k}", g)["id"] for k, g in enumerate(goals)]
    dmin, t = math.inf, svc.world.table
    for _ in range(int(limit_s * 10)):
        svc.advance(0.1)
        xy = np.column_stack([t.f["x"], t.f["y"]])
        d = np.hypot(*(xy[:, None] - xy[None]).transpose(2, 0, 1))
        np.fill_diagonal(d, np.inf)
        dmin = min(dmin, float(d.min()))
        if all(svc.task_status(i)["state"] != "active" and svc.task_status(i)["state"] != "queued" for i in ids):
            break
    return dmin, [svc.task_status(i)["state"] for i in ids]


def test_two_robots_head_on_pass_without_collision():
    with FleetService(FleetConfig(world="empty", navigation=PP)) as svc:
        assert svc.avoidance_settings()["type"] == "orca"
        dmin, states = _min_distance_run(svc, [Pose2D(-4, 0, 0), Pose2D(4, 0, math.pi)],
                                         [Pose2D(4, 0, 0), Pose2D(-4, 0, 0)], 60)
        footprints = 2 * svc.world.robot_spec("r0").footprint_radius
        assert dmin > footprints  # ground truth from the world, over the whole run
        assert states == ["succeeded", "succeeded"]
        assert svc.control.stats["collisions"] == 0


def test_without_avoidance_the_same_robots_collide():
    """The control experiment: the measurement above can fail."""
    with FleetService(FleetConfig(world="empty", navigation=PP, avoidance={"type": "none"})) as svc:
        dmin, _ = _min_distance_run(svc, [Pose2D(-4, 0, 0), Pose2D(4, 0, math.pi)],
                                    [Pose2D(4, 0, 0), Pose2D(-4, 0, 0)], 15)
        assert dmin < 2 * svc.world.robot_spec("r0").footprint_radius
        assert svc.control.stats["collisions"] > 0


def test_four_robots_swapping_corners_all_arrive():
    with FleetService(FleetConfig(world="empty", navigation=PP)) as svc:
        corners = [(3.0, 3.0), (-3.0, 3.0), (-3.0, -3.0), (3.0, -3.0)]
        starts = [Pose2D(x, y, math.atan2(-y, -x)) for x, y in corners]
        goals = [Pose2D(-x, -y, 0.0) for x, y in corners]
        dmin, states = _min_distance_run(svc, starts, goals, 90)
        assert states == ["succeeded"] * 4  # no deadlock lasts forever
        assert dmin > 2 * svc.world.robot_spec("r0").footprint_radius
        assert svc.control.stats["collisions"] == 0


def test_settings_come_from_config_and_change_through_the_facade():
    cfg = FleetConfig(world="empty", avoidance={"type": "orca", "time_horizon": 3.0, "max_neighbors": 4})
    with FleetService(cfg) as svc:
        assert isinstance(svc.control.avoidance, OrcaFilter)
        s = svc.avoidance_settings()
        assert (s["time_horizon"], s["max_neighbors"], s["neighbor_dist"]) == (3.0, 4, 4.0)
        s = svc.set_avoidance(neighbor_dist=6.0)
        assert (s["time_horizon"], s["neighbor_dist"]) == (3.0, 6.0)  # the others kept
        assert svc.set_avoidance("none") == {"type": "none"}
        assert isinstance(svc.control.avoidance, NoAvoidance)
        with pytest.raises(FleetError) as err:
            svc.set_avoidance("orca", time_horizn=2.0)
        assert err.value.code is ErrorCode.INVALID_CONFIG and "time_horizn" in err.value.message
        with pytest.raises(FleetError, match="known avoidances: none, orca"):
            svc.set_avoidance("rvo9")
    with pytest.raises(FleetError, match="known avoidances"):
        FleetService(FleetConfig(world="empty", avoidance={"type": "cbf"}))


def test_registering_a_name_twice_raises():
    with pytest.raises(FleetError, match="already registered"):
        register_avoidance("orca", AvoidanceConfig)(OrcaFilter)
