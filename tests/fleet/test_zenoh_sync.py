"""`agent.sync()`: velocity commands have no reply, so an agent that must know they were applied (and close(),
before the session's end can overtake them) asks for a barrier behind them on the same link."""

from __future__ import annotations

from fleet.agent import Agent
from tests.fleet.zenoh_util import events_of, served, wait_until

START = {"r1": (0.0, 0.0, 0.0)}


def test_sync_returns_after_every_earlier_velocity_command_was_applied():
    with served(robots=START, clock="fast") as (svc, bridge, ep), Agent("pilot", connect=ep) as agent:
        link = agent.robot("r1", streams=())
        for round_ in range(5):
            for i in range(20):
                link.drive(0.01 * (i + 1), 0.0, duration=3600.0)  # held: the fast clock outruns the deadman
            assert agent.unsynced
            agent.sync()
            assert not agent.unsynced
            # read at once, no polling: all 20 went through the envelope (applied, or past the robot's rate limit
            # of 40 commands a second: rejected) before the barrier's reply
            commands = bridge.stats()["commands"]
            assert commands["applied"] + commands["rejected"] == 20 * (round_ + 1)
            if round_ == 0:
                assert commands["rejected"] == 0 and svc.safety.manual["r1"].v == 0.2


def test_a_stop_sent_just_before_closing_is_applied_not_dropped_as_late():
    with served(robots=START, clock="fast") as (svc, bridge, ep):
        for n in range(1, 21):  # the overtaking is a race: try it often
            with Agent(f"brief{n}", connect=ep) as agent:
                link = agent.robot("r1", streams=())
                link.drive(0.3, 0.0)
                link.stop()
            wait_until(lambda n=n: len(events_of(svc, "agent_left")) == n, what=f"agent {n} gone")  # type: ignore[misc]
            commands = bridge.stats()["commands"]
            assert (commands["applied"], commands["rejected"]) == (2 * n, 0)
            assert svc.snapshot.robot("r1").cmd_v == 0.0
