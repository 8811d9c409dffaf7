"""The server's contract: annotations, sim time in every output schema, read-only mode, every tool tested and
documented, the gazebo-mcp floor covered, resources and prompts."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

import pytest
from mcp.client import Client
from PIL import Image

from fleet import FleetService
from mcp_server.server import build_server
from sim import Pose2D
from tests.mcp_server.helpers import err

pytestmark = pytest.mark.anyio
ROOT = Path(__file__).resolve().parents[2]


async def test_every_tool_is_annotated_described_and_answers_with_sim_time(client) -> None:
    tools = (await client.list_tools()).tools
    assert len(tools) >= 100
    for t in tools:
        a = t.annotations
        assert a is not None and a.read_only_hint is not None and a.title, t.name
        assert a.read_only_hint or a.destructive_hint is not None, t.name
        assert t.description and t.description.strip(), t.name
        assert t.output_schema is not None and "sim_time" in t.output_schema["properties"], t.name
    destructive = {t.name for t in tools if t.annotations is not None and t.annotations.destructive_hint}
    assert {"reset_simulation", "load_world", "delete_model", "remove_robot", "restore_snapshot"} <= destructive


async def test_read_only_mode_exposes_only_read_only_tools(service: FleetService) -> None:
    async with Client(build_server(service, read_only=True)) as c:
        tools = (await c.list_tools()).tools
        assert tools and all(t.annotations is not None and t.annotations.read_only_hint for t in tools)
        names = {t.name for t in tools}
        assert "list_robots" in names and "drive_robot" not in names and "reset_simulation" not in names
        await err(c, "drive_robot", {"robot": "r1", "v": 1, "w": 0}, "NOT_FOUND")
    assert service.read_only  # enforced by the service too (tests/mcp_server/test_hostile.py)
    service.read_only = False  # the module's service is shared with the other tests


async def test_every_tool_is_exercised_by_a_test_and_documented(client) -> None:
    names = {t.name for t in (await client.list_tools()).tools}
    sources = "".join(p.read_text() for p in Path(__file__).parent.glob("test_*.py") if p.name != Path(__file__).name)
    untested = sorted(n for n in names if f'"{n}"' not in sources)
    assert not untested, f"tools without an in-memory test: {untested}"
    doc = (ROOT / "docs" / "mcp-tools.md").read_text()
    undocumented = sorted(n for n in names if f"`{n}`" not in doc)
    assert not undocumented, f"tools missing from docs/mcp-tools.md: {undocumented}"


async def test_the_gazebo_mcp_floor_maps_to_existing_tools(client) -> None:
    names = {t.name for t in (await client.list_tools()).tools}
    readme = (ROOT.parent / "shared" / "seeds" / "gazebo-mcp-readme.txt")
    doc = (ROOT / "docs" / "mcp-tools.md").read_text()
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| `(gazebo_\w+)` \| (.+?) \|", doc, re.M)}
    if readme.is_file():
        theirs = set(re.findall(r"^(gazebo_\w+)\s*$", readme.read_text(), re.M))
        assert len(theirs) == 69 and theirs <= set(rows), sorted(theirs - set(rows))
    assert len(rows) == 69
    for gz, ours in rows.items():
        mapped = re.findall(r"`(\w+)`", ours)
        assert mapped and all(m in names for m in mapped if not m.startswith("fleetnav")), (gz, mapped)


async def test_resources_serve_fleet_state_robot_state_and_the_map(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(1.0, 2.0, 0.0))
    uris = {str(r.uri) for r in (await client.list_resources()).resources}
    assert {"fleetnav://fleet/state", "fleetnav://map.png"} <= uris
    templates = {t.uri_template for t in (await client.list_resource_templates()).resource_templates}
    assert "fleetnav://robots/{name}" in templates
    state = json.loads((await client.read_resource("fleetnav://fleet/state")).contents[0].text)
    assert state["robots"] == 1 and state["names"] == "r1" and "sim_time" in state
    robot = json.loads((await client.read_resource("fleetnav://robots/r1")).contents[0].text)
    assert (robot["x"], robot["y"]) == (1.0, 2.0)
    png = (await client.read_resource("fleetnav://map.png")).contents[0]
    import base64

    assert png.mime_type == "image/png" and Image.open(io.BytesIO(base64.b64decode(png.blob))).size[0] > 100
    with pytest.raises(Exception, match=r"ghost|Error"):
        await client.read_resource("fleetnav://robots/ghost")


async def test_prompts_name_the_tools_to_use(client) -> None:
    prompts = {p.name for p in (await client.list_prompts()).prompts}
    assert prompts == {"drive_to_goal", "map_with_slam", "fleet_checkup"}
    p = await client.get_prompt("drive_to_goal", {"robot": "r7", "x": "1", "y": "2"})
    text = p.messages[0].content.text
    assert "r7" in text and "navigate_to" in text and "wait_for_task" in text
