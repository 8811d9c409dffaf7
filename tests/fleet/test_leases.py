"""The safety envelope's lease and rate mechanics in-process (the multi-process side: test_zenoh_leases.py)."""

from __future__ import annotations

import time

import pytest

from fleet.safety import SafetyConfig, SafetyEnvelope
from sim.errors import ErrorCode, FleetError

LIMITS = (1.0, 1.0)
BOUNDS = (-10.0, -10.0, 10.0, 10.0)


def envelope(**kw: float) -> SafetyEnvelope:
    return SafetyEnvelope(SafetyConfig(**kw), BOUNDS, control_hz=10.0)


def test_the_per_robot_limit_defaults_to_four_times_the_control_rate_and_names_itself():
    env = envelope()
    for _ in range(40):
        env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=5.0)
    with pytest.raises(FleetError) as e:
        env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=5.0)
    assert e.value.code is ErrorCode.BUSY
    assert "rate limit 40 commands/s per robot" in e.value.message and "current rate 40/s" in e.value.message
    env.manual_command("a", "r2", 0.1, 0.0, LIMITS, now=5.0)  # another robot has its own budget
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=6.0)  # a sim second later the window has moved on


def test_the_per_agent_ceiling_covers_a_whole_fleet_and_names_itself():
    env = envelope(agent_rate_hz=50)
    for r in range(10):
        for _ in range(5):
            env.manual_command("ctl", f"r{r}", 0.1, 0.0, LIMITS, now=1.0)
    with pytest.raises(FleetError) as e:
        env.manual_command("ctl", "r10", 0.1, 0.0, LIMITS, now=1.0)
    assert "client 'ctl': rate limit 50 commands/s per client" in e.value.message
    assert "current rate 50/s" in e.value.message


def test_a_refused_command_names_the_holder_and_uses_none_of_the_robots_rate():
    env = envelope(robot_rate_hz=3)
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.0)
    for _ in range(10):
        with pytest.raises(FleetError) as e:
            env.manual_command("b", "r1", 0.1, 0.0, LIMITS, now=0.0)
        assert e.value.code is ErrorCode.LEASE_HELD and "client 'a'" in e.value.message
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.0)  # a's 2nd and 3rd still fit
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.0)


def test_a_lease_lapses_after_its_idle_expiry_and_commands_renew_it():
    env = envelope(lease_idle_s=0.2)
    env.acquire("a", "r1")
    for _ in range(4):  # renewed every 0.1 s for 0.4 s: never lapses
        time.sleep(0.1)
        assert env.holder("r1") == "a"
        env.acquire("a", "r1")
    time.sleep(0.3)
    assert env.holder("r1") is None
    env.acquire("b", "r1")


def test_a_departed_client_cannot_take_a_robot_until_it_rejoins():
    env = envelope()
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.0)
    assert env.release_client("a") == ["r1"]
    env.client_left("a")
    with pytest.raises(FleetError) as e:
        env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.1)
    assert "has left" in e.value.message and env.holder("r1") is None
    env.client_joined("a")
    env.manual_command("a", "r1", 0.1, 0.0, LIMITS, now=0.2)
    assert env.holder("r1") == "a"


def test_an_operator_override_takes_the_robot_from_its_holder():
    env = envelope()
    env.manual_command("a", "r1", 0.5, 0.0, LIMITS, now=0.0)
    assert env.override("operator", "r1") == "a"
    assert env.holder("r1") == "operator" and env.active_manual("r1", 0.1) is None  # a's command is gone
    with pytest.raises(FleetError) as e:
        env.manual_command("a", "r1", 0.5, 0.0, LIMITS, now=0.1)
    assert "client 'operator'" in e.value.message
    assert env.override("operator", "r2") is None and env.robots_of("operator") == ["r1", "r2"]
