"""Task specs over MCP (issue 16): `queue_task`/`assign_tasks` advertise a union on the task type whose branches
are the params models of fleet/task_params.py, and a wrong type or field fails naming the valid ones."""

from __future__ import annotations

from typing import Any

import pytest
from mcp.client import Client

from fleet import FleetService
from fleet.task_params import PARAMS
from fleet.tasks import allocatable_types
from tests.mcp_server.helpers import err, ok


async def _schemas(client: Client) -> dict[str, dict[str, Any]]:
    return {t.name: t.input_schema for t in (await client.list_tools()).tools}


@pytest.mark.anyio
async def test_the_task_spec_schema_is_a_union_on_type_with_each_types_params(client: Client) -> None:
    schemas = await _schemas(client)
    spec = schemas["queue_task"]["properties"]["spec"]
    items = next(a for a in schemas["assign_tasks"]["properties"]["tasks"]["anyOf"] if a.get("type") == "array")
    assert items["items"] == {k: v for k, v in spec.items() if k != "description"}  # one definition for both
    assert spec["properties"]["type"]["enum"] == allocatable_types() == ["cover_area", "follow_waypoints", "go_to",
                                                                         "traffic_go"]
    assert spec["discriminator"] == {"propertyName": "type"} and spec["additionalProperties"] is False
    assert {"priority", "earliest_start", "deadline", "id"} <= set(spec["properties"])
    branches = {b["properties"]["type"]["const"]: b["properties"]["params"] for b in spec["oneOf"]}
    assert set(branches) == set(allocatable_types())
    for name, params in branches.items():
        assert params["additionalProperties"] is False, name
        assert set(params["properties"]) == set(PARAMS[name].model_fields), name
        for field, s in params["properties"].items():
            assert s.get("description") or "$ref" in s or "enum" in s, f"{name}.{field} undescribed"
    cover = branches["cover_area"]["properties"]
    assert cover["overlap"]["maximum"] == 0.9 and cover["tool_width"]["minimum"] == 0.05
    assert cover["polygon"]["maxItems"] == 200 and branches["go_to"]["required"] == ["goal"]


@pytest.mark.anyio
async def test_a_wrong_field_or_type_names_the_valid_ones(client: Client, service: FleetService) -> None:
    await ok(client, "spawn_robot", {"name": "r1", "x": -2, "y": -2})
    text = await err(client, "queue_task", {"spec": {"type": "go_to", "params": {"gaol": {"x": 1, "y": 1}}}},
                     "INVALID_ARGUMENT")
    assert "gaol" in text and "goal" in text
    text = await err(client, "queue_task", {"spec": {"type": "wait", "params": {"seconds": 3}}}, "INVALID_ARGUMENT")
    assert "go_to" in text and "cover_area" in text  # the types it takes
    text = await err(client, "assign_tasks", {"dry_run": True, "tasks": [
        {"type": "cover_area", "params": {"polygon": [[0, 0], [2, 0], [2, 2]], "overlap": 0.95}}]}, "INVALID_ARGUMENT")
    assert "overlap" in text
    text = await err(client, "assign_tasks", {"dry_run": True, "tasks": [
        {"type": "follow_waypoints", "params": {"waypoints": [{"x": 1, "y": 1, "speed": 2}]}}]}, "INVALID_ARGUMENT")
    assert "speed" in text
    # a valid spec of each allocatable type is accepted, and [x, y] poses are read as {x, y}
    plan = await ok(client, "assign_tasks", {"dry_run": True, "cost": "euclidean", "tasks": [
        {"type": "go_to", "params": {"goal": [2, 2]}, "id": "a"},
        {"type": "follow_waypoints", "params": {"waypoints": [[1, 0], {"x": 1, "y": 1, "dwell_s": 1}]}, "id": "b"},
        {"type": "cover_area", "params": {"polygon": [[0, 0], [2, 0], [2, 2], [0, 2]], "tool_width": 0.5}, "id": "c"},
    ]})
    assert sorted(a["request"] for a in plan["result"]["assignments"]) == ["a", "b", "c"]
    assert service.list_tasks() == []  # a dry run submits nothing


def _free_objects(node: Any, path: str) -> list[str]:
    """Places in a schema that accept an object without saying its keys: a free-form dict."""
    out: list[str] = []
    if isinstance(node, dict):
        keyed = {"properties", "propertyNames", "oneOf", "anyOf", "$ref"} & set(node)
        if node.get("type") == "object" and not keyed:
            out.append(path)
        if node.get("additionalProperties") not in (None, False):
            out.append(f"{path} (additionalProperties)")
        for k, v in node.items():
            out += _free_objects(v, f"{path}/{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _free_objects(v, f"{path}[{i}]")
    return out


@pytest.mark.anyio
async def test_no_tool_takes_a_free_form_dict(client: Client) -> None:
    """Every config/params/settings/options argument of every tool is typed (its keys are in the schema)."""
    free = [f"{name}{p}" for name, schema in (await _schemas(client)).items() for p in _free_objects(schema, "")]
    # the task spec's `params` is given per type by the oneOf branches next to it
    free = [p for p in free if not p.endswith("/properties/params")]
    assert not free, free
