"""Killing an agent process: its robot stops within the deadman and the world says so on `fleet/events`."""

from __future__ import annotations

from fleet.agent import Agent
from tests.fleet.zenoh_util import events_of, example, served, wait_until

START = {"r1": (-5.0, -5.0, 0.0)}


def test_killing_the_agent_stops_its_robot_within_the_deadman_and_says_so():
    with served("robot_arena", robots=START, speed=2.0) as (svc, _, ep), Agent("observer", connect=ep) as observer:
        proc = example("goal_seeker.py", "--connect", ep, "--robot", "r1", "--goal", "5", "-4", "--timeout", "60")
        wait_until(lambda: svc.snapshot.robot("r1").v > 0.3, timeout=30, what="the agent driving r1")
        proc.kill()
        killed_at = svc.snapshot.time
        proc.wait(timeout=10)
        wait_until(lambda: svc.snapshot.robot("r1").cmd_v == 0.0, what="the stop command")
        commanded_stop = svc.snapshot.time
        wait_until(lambda: svc.snapshot.robot("r1").v == 0.0, what="standstill")
        stopped = svc.snapshot.time
        deadman, period = svc.config.safety.deadman_s, 1.0 / svc.config.control_hz
        assert commanded_stop - killed_at <= deadman + period
        # braking from ≤ 0.6 m/s at the diffbot's 1.5 m/s² takes ≤ 0.4 s more
        assert stopped - killed_at <= deadman + period + 0.6 / 1.5 + period
        lost = events_of(svc, "client_lost")
        assert [(e.robots, e.data["client"]) for e in lost] == [(("r1",), "goal_seeker")]
        assert observer.wait_for(lambda: any(e["kind"] == "client_lost" and e["robots"] == ["r1"]
                                             for e in observer.events))
