"""Deadlocks: the wait-for cycle finder, detection on a constructed cycle, resolution by priority."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import ErrorCode, FleetConfig, FleetError, FleetService
from fleet.deadlock import wait_for_cycles
from sim import Pose2D

PP = {"controller": {"type": "pure_pursuit"}}


def test_cycles_are_the_strongly_connected_groups():
    assert wait_for_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [("a", "b", "c")]
    assert wait_for_cycles({"a": {"b"}, "b": {"c"}}) == []  # a chain is not a deadlock
    assert wait_for_cycles({"a": {"b"}, "b": {"a"}, "x": {"y"}, "y": {"x"}}) == [("a", "b"), ("x", "y")]
    assert wait_for_cycles({}) == []


def _ring(svc: FleetService, n: int, side: float) -> list[str]:
    """n robots on a polygon, each facing the next and sent past it: every one waits on the next."""
    r = side / (2 * math.sin(math.pi / n))
    pts = [np.array([r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n)]) for k in range(n)]
    ids = []
    for k in range(n):
        d = pts[(k + 1) % n] - pts[k]
        svc.spawn_robot(f"r{k}", Pose2D(float(pts[k][0]), float(pts[k][1]), math.atan2(d[1], d[0])))
    for k in range(n):
        d = pts[(k + 1) % n] - pts[k]
        g = pts[(k + 1) % n] + 2.0 * d / np.hypot(*d)
        ids.append(svc.navigate(f"r{k}", Pose2D(float(g[0]), float(g[1]), 0.0))["id"])
    return ids


def test_a_constructed_cycle_is_detected_and_names_its_robots():
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP, avoidance={"type": "none"})) as svc:
        svc.configure_deadlocks(policy="none")
        _ring(svc, 3, 1.1)
        svc.advance(8.0)
        events = svc.events.since(0, kinds=["deadlock"])
        assert len(events) == 1
        ev = events[0]
        assert ev.robots == ("r0", "r1", "r2") and ev.data["type"] == "cycle"
        assert 3.0 <= ev.stamp <= 6.0  # after wait_s without progress, at a check
        rep = svc.deadlock_report()
        assert rep["detected"] == 1 and rep["active"][0]["robots"] == ["r0", "r1", "r2"]
        assert rep["active"][0]["action"] == "reported only"


def test_priority_policy_lets_the_higher_priority_robot_through_first():
    """Head-on without avoidance: they jam nose to nose. The lower-priority robot backs off out of the lane,
    the other goes, then it follows; both arrive, far sooner than the navigators' own recoveries manage."""
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP, avoidance={"type": "none"})) as svc:
        svc.spawn_robot("a", Pose2D(-3.0, 0.0, 0.0))
        svc.spawn_robot("b", Pose2D(3.0, 0.05, math.pi))
        ta = svc.submit_task("go_to", "a", {"goal": Pose2D(3.0, 0.0, 0.0)}, priority=1)["id"]
        tb = svc.navigate("b", Pose2D(-3.0, 0.0, 0.0))["id"]
        for _ in range(40):
            svc.advance(1.0)
            if svc.task_status(ta)["state"] == svc.task_status(tb)["state"] == "succeeded":
                break
        assert svc.task_status(ta)["state"] == svc.task_status(tb)["state"] == "succeeded"
        assert svc.task_status(ta)["finished"] < svc.task_status(tb)["finished"]  # the winner went first
        rep = svc.deadlock_report()
        first = rep["recent"][0]
        assert first["robots"] == ["a", "b"] and first["winner"] == "a" and first["state"] == "resolved"
        assert rep["resolved"] >= 1
        kinds = [e.kind for e in svc.events.since(0, kinds=["deadlock", "deadlock_resolved"])]
        assert kinds[:2] == ["deadlock", "deadlock_resolved"]


def test_deadlock_settings_are_validated():
    with FleetService(FleetConfig(world="empty")) as svc:
        assert svc.configure_deadlocks(stall_s=20.0)["stall_s"] == 20.0
        with pytest.raises(FleetError) as err:
            svc.configure_deadlocks(policy="shout")
        assert err.value.code is ErrorCode.INVALID_CONFIG and "policy" in err.value.message
