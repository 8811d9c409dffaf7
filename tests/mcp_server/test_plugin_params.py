"""Typed settings for swarm behaviours and avoidance: tools/list shows each registered type's fields, a wrong
field is an INVALID_ARGUMENT naming it (and nothing changes), a right one takes effect."""

from __future__ import annotations

from typing import Any

import pytest
from mcp.client import Client

from fleet import FleetService
from fleet.avoidance import avoidance_configs
from fleet.swarm import behaviour_configs
from sim import Pose2D
from tests.mcp_server.helpers import err, ok


async def _schema(client: Client, tool: str, param: str) -> dict[str, Any]:
    tools = {t.name: t for t in (await client.list_tools()).tools}
    prop: dict[str, Any] = tools[tool].input_schema["properties"][param]
    return prop


def _alternatives(prop: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {a["description"].split("'")[1]: a for a in prop["anyOf"] if a.get("type") == "object"}


@pytest.mark.anyio
async def test_every_behaviour_and_avoidance_type_has_a_typed_schema(client: Client) -> None:
    prop = await _schema(client, "start_swarm_behaviour", "params")
    alts = _alternatives(prop)
    assert set(alts) == set(behaviour_configs()) == {"flocking", "coverage", "formation", "leader_follower",
                                                     "rendezvous"}
    for name, alt in alts.items():
        fields = set(behaviour_configs()[name].model_fields) - {"type"}
        assert set(alt["properties"]) == fields and alt["additionalProperties"] is False, name
    assert alts["coverage"]["required"] == ["polygon"]
    assert "cruise speed" in alts["flocking"]["properties"]["speed"]["description"]
    assert prop["description"]
    s = await _schema(client, "set_collision_avoidance", "settings")
    a = _alternatives(s)
    assert set(a) == set(avoidance_configs()) and {"time_horizon", "neighbor_dist"} <= set(a["orca"]["properties"])
    assert a["none"]["properties"] == {}
    assert "$ref" not in str(prop) + str(s)


@pytest.mark.anyio
async def test_a_wrong_field_is_named_and_changes_nothing(client: Client, service: FleetService) -> None:
    for i in range(3):
        service.spawn_robot(f"r{i}", Pose2D(2.0 * i, 0, 0))
    msg = await err(client, "start_swarm_behaviour", {"behaviour": "flocking", "params": {"sped": 0.2}},
                    "INVALID_ARGUMENT")
    assert "sped" in msg and "speed" in msg  # the typo and the valid fields
    msg = await err(client, "start_swarm_behaviour", {"behaviour": "flocking", "params": {"speed": -1}},
                    "INVALID_ARGUMENT")
    assert "speed" in msg
    # a field of another behaviour is wrong for this one
    msg = await err(client, "start_swarm_behaviour", {"behaviour": "rendezvous", "params": {"shape": "line"}},
                    "INVALID_ARGUMENT")
    assert "shape" in msg and "'rendezvous'" in msg
    await err(client, "start_swarm_behaviour", {"behaviour": "coverage", "params": {}}, "INVALID_ARGUMENT")
    assert (await ok(client, "swarm_status"))["items"] == []
    out = await ok(client, "start_swarm_behaviour", {"behaviour": "flocking", "params": {"speed": 0.2}})
    assert service.behaviours.running[out["result"]["id"]].params["speed"] == 0.2

    before = (await ok(client, "get_collision_avoidance"))["result"]
    msg = await err(client, "set_collision_avoidance", {"settings": {"time_horizont": 3.0}}, "INVALID_ARGUMENT")
    assert "time_horizont" in msg and "time_horizon" in msg
    await err(client, "set_collision_avoidance", {"plugin": "none", "settings": {"time_horizon": 3.0}},
              "INVALID_ARGUMENT")
    assert (await ok(client, "get_collision_avoidance"))["result"] == before
    after = (await ok(client, "set_collision_avoidance", {"settings": {"time_horizon": 3.0}}))["result"]
    assert after["time_horizon"] == 3.0 and after["type"] == before["type"]
