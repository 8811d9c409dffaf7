"""Swarm behaviours with a goal shape: Lloyd coverage, formation keeping, leader-follower."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import FleetConfig, FleetError, FleetService
from fleet.formations import assign_slots, formation_offsets
from sim import Pose2D

SQUARE = [(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)]


def test_lloyd_coverage_lowers_the_coverage_cost():
    with FleetService(FleetConfig(world="empty", seed=2)) as svc:
        svc.spawn_fleet(5, "grid", Pose2D(-2.8, -2.8, 0.0), spacing=1.0, prefix="c")
        b = svc.start_behaviour("coverage", None, {"polygon": SQUARE, "sensing_radius": 2.0})
        svc.advance(25.0)
        st = svc.behaviour_status(b["id"], history=True)
        cost = np.array([h["lloyd_cost"] for h in st["history"]])
        assert cost[-1] < 0.4 * cost[0]
        rises = np.diff(cost)[np.diff(cost) > 0]
        assert rises.sum() < 0.02 * cost[0]  # monotone up to small wobbles (robots are not point masses)
        assert st["metrics"]["coverage_pct"] > st["initial_metrics"]["coverage_pct"] + 30
        assert st["converged"]
        assert svc.control.stats["collisions"] == 0
        # Lloyd's fixed point for 5 robots on an 8 m square: each one near its cell's centroid
        assert st["metrics"]["centroid_error_m"] <= 0.15


def test_coverage_polygon_is_validated():
    with FleetService(FleetConfig(world="empty")) as svc:
        svc.spawn_fleet(2, "line", Pose2D(0, 0, 0), spacing=1.5)
        with pytest.raises(FleetError, match="polygon"):
            svc.start_behaviour("coverage", None, {"polygon": [(0, 0), (1, 1)]})


def test_formation_keeping_forms_the_shape_and_carries_it_to_the_goal():
    with FleetService(FleetConfig(world="empty", seed=6)) as svc:
        rng = np.random.default_rng(3)
        for k, (x, y) in enumerate([(-3.5, -1.0), (-1.0, -3.5), (-3.0, 2.0), (0.5, -1.0), (-1.5, 0.5)]):
            svc.spawn_robot(f"f{k}", Pose2D(x, y, float(rng.uniform(-math.pi, math.pi))))
        b = svc.start_behaviour("formation", None, {"shape": "circle", "spacing": 1.5, "yaw": 0.0,
                                                    "goal": (1.5, 1.0)})
        assert svc.behaviour_status(b["id"])["initial_metrics"]["formation_error_m"] > 0.8
        svc.advance(24.0)
        st = svc.behaviour_status(b["id"])
        assert st["converged"] and st["metrics"]["formation_error_m"] < 0.15
        assert st["metrics"]["centre_to_goal_m"] < 0.05
        # the tracked points form the closed-form circle about the goal
        pts = np.array([[r.pose.x + 0.15 * math.cos(r.pose.yaw), r.pose.y + 0.15 * math.sin(r.pose.yaw)]
                        for r in svc.snapshot.robots()])
        assert np.hypot(*(pts - (1.5, 1.0)).T) == pytest.approx(np.full(5, 1.5 / (2 * math.sin(math.pi / 5))),
                                                                 abs=0.15)
        assert svc.control.stats["collisions"] == 0


def test_followers_keep_their_slots_behind_a_navigating_leader():
    cfg = FleetConfig(world="empty", seed=1, navigation={"controller": {"type": "pure_pursuit"}})
    with FleetService(cfg) as svc:
        svc.spawn_fleet(3, "wedge", Pose2D(-3.0, 0.0, 0.0), spacing=1.5, prefix="w")
        b = svc.start_behaviour("leader_follower", None, {"leader": "w1", "shape": "wedge", "spacing": 1.5})
        task = svc.navigate("w1", Pose2D(2.5, 0.5, 0.0), align_yaw=True)
        svc.advance(25.0)
        assert svc.task_status(task["id"])["state"] == "succeeded"
        st = svc.behaviour_status(b["id"])
        assert st["metrics"]["formation_error_m"] < 0.25
        # followers sit at the wedge slots behind the leader, in its body frame
        lead = svc.robot("w1").pose
        want = formation_offsets("wedge", 3, 1.5)
        want = want[1:] - want[0]
        got = []
        for r in ("w2", "w3"):
            p = svc.robot(r).pose
            px, py = p.x + 0.15 * math.cos(p.yaw) - lead.x - 0.15 * math.cos(lead.yaw), \
                p.y + 0.15 * math.sin(p.yaw) - lead.y - 0.15 * math.sin(lead.yaw)
            c, s = math.cos(lead.yaw), math.sin(lead.yaw)
            got.append((c * px + s * py, -s * px + c * py))
        got_a = np.array(got)
        assert np.abs(got_a - want[assign_slots(got_a, want)]).max() < 0.3
        assert svc.control.stats["collisions"] == 0
