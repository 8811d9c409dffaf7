"""Lock-step: the world waits each control tick for its agents, so a slow agent sees every tick and a run is
deterministic; an agent that stops answering is declared hung and its robot stopped."""

from __future__ import annotations

from typing import Any

import numpy as np

from fleet.agent import Agent
from fleet.zenoh_config import LockstepConfig
from sim.errors import ErrorCode
from tests.fleet.zenoh_util import events_of, example, result_of, served, wait_until

START = {"r1": (-5.0, -5.0, 0.0)}


def _follow_wall_in_lockstep(seed: int) -> tuple[np.ndarray, dict[str, Any], dict[str, Any]]:
    """One run: the world paused until the agent process registers, then as fast as the agent allows."""
    with served("robot_arena", seed=seed, robots=START, clock="paused",
                lockstep=LockstepConfig(enabled=True, timeout_s=10.0)) as (svc, bridge, ep):
        track: list[list[float]] = []
        svc.tick_listeners.append(lambda s: track.append([s.time, *map(float, s.pose[0])]))
        proc = example("wall_follower.py", "--connect", ep, "--robot", "r1", "--lockstep", "--duration", "4",
                       "--delay", "0.02", "--timeout", "30")
        wait_until(lambda: "wall_follower" in bridge.gate.agents, timeout=30, what="lock-step registration")
        svc.run_fast()
        out = result_of(proc, timeout=60)
        stats = bridge.stats()
        svc.pause()
    return np.array(track), out, stats


def test_a_slow_agent_gets_every_tick_and_the_run_repeats_exactly():
    track1, out1, stats1 = _follow_wall_in_lockstep(seed=7)
    track2, out2, _ = _follow_wall_in_lockstep(seed=7)
    assert out1["ticks"] == list(range(40))  # 4 s at 10 Hz, from tick 0, none skipped
    # ticks 0–39 answered with a command each, then the example's closing stop; none rejected
    assert stats1["commands"]["received"] == 40 + 1 and stats1["commands"]["rejected"] == 0
    # the world ran only as far as the 20 ms-per-tick agent allowed, and repeated bit for bit up to tick 40,
    # where the agent left lock-step (after that the world runs free on wall timing: not compared)
    assert len(track1) > 41 and len(track2) > 41
    np.testing.assert_array_equal(track1[:41], track2[:41])
    assert track1[40, 0] == 4.1  # sim time after the period of tick 40
    assert np.hypot(*(track1[39, 1:3] - track1[0, 1:3])) > 0.5  # it did move along the wall
    assert out1["closest"] == out2["closest"]


def test_an_agent_that_stops_answering_is_declared_hung_and_its_robot_stopped():
    with served(robots={"r1": (0.0, 0.0, 0.0)}, clock="fast",
                lockstep=LockstepConfig(enabled=True, timeout_s=0.3)) as (svc, bridge, ep), \
            Agent("sleepy", connect=ep) as agent:
        agent.robot("r1").drive_sync(0.5, 0.0, duration=600.0)  # would run on forever without the gate
        reply = agent.request("lockstep", robots=["r1"])
        assert reply["robots"] == ["r1"] and reply["control_period"] == 0.1
        wait_until(lambda: events_of(svc, "agent_hung"), timeout=10, what="agent_hung")
        ev = events_of(svc, "agent_hung")[0]
        assert ev.robots == ("r1",) and ev.data["stopped"] == ["r1"]
        assert agent.wait_for(lambda: any(e["code"] == ErrorCode.TIMEOUT.value for e in agent.errors))
        t = svc.snapshot.time
        wait_until(lambda: svc.snapshot.time > t + 1.0, what="the world running on without it")
        assert svc.snapshot.robot("r1").cmd_v == 0.0 and bridge.gate.agents == {}
