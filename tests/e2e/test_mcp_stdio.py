"""`fleetnav serve` launched as a stdio subprocess by the MCP SDK's stdio client: a robot driven to a goal
through MCP alone (spawn → plan → navigate → wait with progress → check the pose)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from mcp.client import Client
from mcp.client.stdio import StdioServerParameters

from tests.mcp_server.helpers import text_of

pytestmark = pytest.mark.anyio
FLEETNAV = str(Path(sys.executable).with_name("fleetnav"))


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    return "asyncio"


async def drive_to_goal(c: Client) -> None:
    """The scenario both transports run: everything through tool calls, checked through tool calls."""
    await c.call_tool("spawn_robot", {"name": "r1", "x": 0.0, "y": 0.0})
    plan = (await c.call_tool("plan_path", {"robot": "r1", "x": 3.0, "y": 1.0})).structured_content
    assert plan is not None and plan["length_m"] == pytest.approx(math.hypot(3.0, 1.0), abs=0.1)
    task = json.loads(text_of(await c.call_tool("navigate_to", {"robot": "r1", "x": 3.0, "y": 1.0})))
    seen: list[float] = []

    async def on_progress(progress: float, total: float | None, message: str | None) -> None:
        seen.append(progress)

    w = await c.call_tool("wait_for_task", {"task_id": task["task"]["id"], "timeout_s": 60, "max_wall_s": 60},
                          progress_callback=on_progress)
    assert not w.is_error and w.structured_content["task"]["state"] == "succeeded", text_of(w)
    assert seen, "the waiting tool sent progress notifications"
    state = (await c.call_tool("get_robot_state", {"robot": "r1"})).structured_content["robot"]
    assert math.hypot(state["x"] - 3.0, state["y"] - 1.0) < 0.3
    err = await c.call_tool("get_robot_state", {"robot": "ghost"})
    assert err.is_error and text_of(err).startswith("UNKNOWN_ROBOT: ")


async def test_stdio_server_drives_a_robot_to_a_goal(tmp_path: Path) -> None:
    params = StdioServerParameters(command=FLEETNAV, args=["serve", "--world", "empty", "--speed", "10",
                                                          "--workspace", str(tmp_path)])
    async with Client(params) as c:
        status = (await c.call_tool("sim_status", {})).structured_content
        assert status["clock"] == "realtime" and status["speed"] == 10.0  # service mode: the sim thread runs
        await drive_to_goal(c)
