"""Agents in their own processes (examples/*.py) against a world served over Zenoh on loopback."""

from __future__ import annotations

import math

import pytest

from fleet.agent import Agent
from sim.errors import ErrorCode, FleetError
from tests.fleet.zenoh_util import events_of, example, result_of, served, wait_until

START = {"r1": (-5.0, -5.0, 0.0)}


def test_an_agent_process_drives_a_robot_around_obstacles_to_its_goal():
    # robot_arena's south corridor: the straight line to (0, -4.2) clips the crate at (-3.5, -4.2) and the wall
    # stub at x = -1; the goal seeker must steer around both
    with served("robot_arena", robots=START, speed=5.0) as (svc, _, ep):
        proc = example("goal_seeker.py", "--connect", ep, "--robot", "r1", "--goal", "0", "-4.2", "--timeout", "60")
        out = result_of(proc, timeout=90)
        assert proc.returncode == 0 and out["reached"] and out["errors"] == []
        p = svc.snapshot.robot("r1").pose
        assert math.hypot(p.x - 0.0, p.y + 4.2) < 0.35
        assert events_of(svc, "collision") == []
        assert out["sim_time"] > 5.0  # ~5 m at ≤ 0.6 m/s: the agent saw sim time advance


def test_two_agents_cannot_both_control_one_robot():
    with served("robot_arena", robots=START, speed=2.0) as (svc, _, ep), Agent("intruder", connect=ep) as intruder:
        proc = example("wall_follower.py", "--connect", ep, "--robot", "r1", "--duration", "600", "--timeout", "60")
        try:
            wait_until(lambda: svc.safety.holder("r1") == "wall_follower", timeout=30, what="the follower's lease")
            with pytest.raises(FleetError) as e:
                intruder.robot("r1").drive_sync(0.0, 1.0)
            assert e.value.code is ErrorCode.LEASE_HELD and "wall_follower" in e.value.message
            with pytest.raises(FleetError) as e:
                intruder.navigate("r1", 0.0, -4.0)
            assert e.value.code is ErrorCode.LEASE_HELD
            assert svc.safety.holder("r1") == "wall_follower"
        finally:
            proc.kill()
            proc.wait(timeout=10)
        wait_until(lambda: svc.safety.holder("r1") is None, what="the lease released with the process")
        assert intruder.robot("r1").drive_sync(0.0, 0.5)["applied_w"] == 0.5  # free to take over now
