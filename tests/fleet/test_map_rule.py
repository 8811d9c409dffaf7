"""`map_source: sensors` is the graded default, and under it nobody is handed the world's occupancy map: an
agent's Zenoh query (real sessions on loopback, scouting off), the MCP map image, and a navigator the agent
starts with `navigate` all get only what the lidar saw. `prior` stays available when chosen explicitly."""

from __future__ import annotations

import pytest

from fleet.agent import Agent
from fleet.grading.challenge import CHALLENGES, load_challenge
from fleet.grading.runner import navigation_settings
from sim.errors import ErrorCode, FleetError
from tests.fleet.zenoh_util import served


def test_every_shipped_challenge_defaults_to_sensors_and_prior_is_an_explicit_choice(tmp_path):
    shipped = sorted(CHALLENGES.glob("*.yaml"))
    assert len(shipped) >= 6
    for f in shipped:
        assert load_challenge(f).map_source == "sensors", f.name
    known = tmp_path / "warehouse.yaml"
    known.write_text("name: known\nworld: robot_arena\nstart: spawn_start\ngoal: goal_marker\ntime_limit: 60\n"
                     "map_source: prior\n", encoding="utf-8")
    ch = load_challenge(known)
    assert ch.map_source == "prior"
    assert navigation_settings(ch, "builtin:pure_pursuit")["map_source"] == "prior"


def test_under_a_sensors_rule_the_agent_is_refused_the_map_and_navigate_uses_only_the_lidar():
    with served("robot_arena", robots={"r1": (-5.0, -5.0, 0.0)}) as (svc, _, ep), \
            Agent("contestant", connect=ep) as agent:
        grid, _, _ = agent.occupancy_map()  # no rule yet: a fleet client gets the world's map
        assert (grid == 100).any()
        assert svc.nav_config().map_source == "prior"
        svc.call(lambda: svc.withhold_prior_map("challenge maze"))
        with pytest.raises(FleetError) as e:
            agent.occupancy_map()
        assert e.value.code is ErrorCode.UNSUPPORTED
        assert "map_source: sensors" in e.value.message and "challenge maze" in e.value.message
        with pytest.raises(FleetError, match="map_source: sensors"):
            svc.map_image()  # the MCP get_occupancy_map of the static map
        assert svc.nav_config().map_source == "sensors"  # a `navigate` the agent asks for plans on the lidar only
        cm = svc.call(lambda: svc.costmap_for("r1"))
        assert not cm.lethal_mask[cm.grid.world_to_cell(0.0, 1.5)]  # barrier_north, not seen from the start


def test_under_a_sensors_rule_the_live_view_publishes_no_map():
    """The live view's port is as reachable as the bridge's for a process on this machine: no /map either."""
    import foxglove

    from fleet import FleetConfig, FleetService
    from fleet.recording.publisher import FoxglovePublisher

    for rule, maps in ((None, 1), ("challenge maze", 0)):
        svc = FleetService(FleetConfig(world="robot_arena", seed=1))
        try:
            if rule is not None:
                svc.withhold_prior_map(rule)
            pub = FoxglovePublisher(svc, foxglove.Context())
            svc.step(20)
            assert pub.counts["/map"] == maps
            pub.close()
        finally:
            svc.close()
