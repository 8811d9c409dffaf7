"""The fleet's planning map has no artificial bounds, and `navigation.map_source` decides what it knows."""

from __future__ import annotations

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from sim import Pose2D


def test_a_goal_far_outside_the_default_map_is_planned_to():
    svc = FleetService(FleetConfig(world="empty", seed=1))
    try:
        svc.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
        goal = Pose2D(40.0, -3.0, 0.0)  # 30 m beyond the 20 m × 20 m map an empty world used to get
        plan = svc.plan_path("r1", goal)
        assert np.allclose(plan.path[-1], [goal.x, goal.y], atol=0.05)
        assert svc.static_grid().bounds[2] >= goal.x + 1.0  # the map grew to hold the goal
    finally:
        svc.close()


@pytest.mark.parametrize(("source", "prior_lethal"), [("prior", True), ("sensors", False)])
def test_map_source_sensors_starts_from_an_unknown_map_and_learns_from_the_lidar(source, prior_lethal):
    svc = FleetService(FleetConfig(world="robot_arena", seed=1, navigation={"map_source": source}))
    try:
        svc.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.0))  # the arena's spawn_start
        cm = svc.costmap_for("r1")
        assert bool(cm.lethal_mask.any()) is prior_lethal  # sensors: the world file is not read
        svc.advance(0.5)
        scan = svc.world.latest_scan("r1")
        assert scan is not None and np.isfinite(scan.ranges).any()
        cm.update_from_scan(scan, svc.world.robot_pose("r1"))
        assert cm.lethal_mask.any()  # what the lidar saw is in the costmap
        nav = svc.make_navigator("r1")
        assert nav.sensing is (source != "prior")
    finally:
        svc.close()
