"""A Hypothesis state machine over the MCP tools (SDK in-memory client, threaded service): hostile values
(NaN, ±inf, 1e308, huge counts, `../`, absolute paths, `file://`, a symlink out of the workspace, unicode,
wrong types) interleaved with normal calls. After every step the sim thread is alive; `step_simulation`
advances sim time by exactly its steps; every error is a structured FleetError code (never INTERNAL).

Bounded for CI: derandomized, a fixed number of examples and steps (about 300 calls). The counts are printed
(`-s`) and recorded in docs/limits.md.
"""

from __future__ import annotations

import asyncio
import math
import os
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule, run_state_machine_as_test
from mcp.client import Client
from mcp.server.mcpserver import MCPServer

from fleet import FleetConfig, FleetService
from mcp_server.server import build_server
from sim.errors import ErrorCode
from tests.mcp_server.helpers import ERROR_RE, text_of

CODES = set(ErrorCode.__members__) - {"INTERNAL", "SIM_DEAD"}
SECRET_DIR = Path(tempfile.mkdtemp(prefix="fleetnav_secret_"))
(SECRET_DIR / "x.world").write_text("<sdf version='1.9'><world name='secret'/></sdf>")
(SECRET_DIR / "x.yaml").write_text("secret_key: 1\n")

HOSTILE: list[Any] = [
    "NaN", "Infinity", "-Infinity", 1e308, -1e308, 10**12, -(10**12), 0, -1, "", "../../etc/passwd",
    "../../../etc/x.world", "/etc/shadow", "file:///etc/passwd", f"file://{SECRET_DIR}/x.world", "link/x.world",
    "link/x.yaml", "机器人\u202e\x00", "a" * 5000, [], {}, None, True, [[1e308, 0]], {"x": "NaN"},
]
# tool → (argument to make hostile, the other arguments of a call that would otherwise be sensible)
TARGETS: dict[str, tuple[list[str], dict[str, Any]]] = {
    "spawn_robot": (["name", "x", "y", "yaw", "model"], {"name": "h1", "x": 1.0, "y": 1.0}),
    "navigate_to": (["robot", "x", "y", "yaw", "planner"], {"robot": "r1", "x": 2.0, "y": 1.0}),
    "plan_path": (["x", "y", "planner"], {"robot": "r1", "x": 2.0, "y": 1.0}),
    "add_keepout_zone": (["polygon"], {"polygon": [[3, 3], [4, 3], [4, 4]]}),
    "set_model_state": (["name", "pose"], {"name": "r1", "pose": {"x": 0.5, "y": 0.0}}),
    "spawn_model": (["file", "xml", "pose"], {"xml": "<sdf version='1.9'><model name='hb'><static>true</static>"
                                                     "<link name='l'/></model></sdf>"}),
    "step_simulation": (["steps"], {"steps": 5}),
    "set_simulation_speed": (["speed"], {"speed": 2.0}),
    "load_world": (["world"], {"world": "empty"}),
    "validate_world": (["world"], {"world": "empty"}),
    "save_world": (["path"], {"path": "m/a.world"}),
    "cover_area": (["polygon", "tool_width"], {"robot": "r1", "polygon": [[0, 0], [2, 0], [2, 2], [0, 2]]}),
    "follow_waypoints": (["waypoints"], {"robot": "r1", "waypoints": [{"x": 1, "y": 1}]}),
    "assign_tasks": (["tasks"], {"tasks": [{"type": "go_to", "params": {"goal": {"x": 1, "y": 1}}}],
                                 "dry_run": True}),
    "start_slam": (["config"], {"robot": "r1"}),
    "read_sensor": (["robot", "sensor"], {"robot": "r1", "sensor": "lidar"}),
    "drive_robot": (["v", "w", "duration"], {"robot": "r1", "v": 0.1, "w": 0.0, "wait": False}),
    "apply_force": (["force"], {"name": "r1", "force": [1.0, 0.0, 0.0]}),
    "load_slam_map": (["path"], {"path": "maps/none.yaml"}),
    "start_recording": (["path"], {"path": "rec/h.mcap"}),
    "get_occupancy_map": (["max_px"], {}),
    "run_mission": (["path"], {"path": "nope"}),
}
STATS: Counter[str] = Counter()
FAILURES: list[str] = []


def _call(server: MCPServer, tool: str, args: dict[str, Any]) -> tuple[bool, str, Any]:
    async def go() -> tuple[bool, str, Any]:
        async with Client(server) as c:
            r = await asyncio.wait_for(c.call_tool(tool, args), 60)
            return r.is_error, text_of(r), r.structured_content

    return asyncio.run(go())


class HostileMCP(RuleBasedStateMachine):
    svc: FleetService
    server: MCPServer

    @initialize()
    def fresh(self) -> None:
        svc = HostileMCP.svc
        if not svc.sim_health()["alive"]:
            svc.restart()
        if svc.world.name != "empty":
            svc.load_world("empty")
        svc.reset()
        svc.pause()
        self.robots = 0

    def call(self, tool: str, args: dict[str, Any], hostile: bool) -> tuple[bool, str, Any]:
        STATS["calls"] += 1
        STATS["hostile" if hostile else "normal"] += 1
        is_error, text, structured = _call(HostileMCP.server, tool, args)
        if is_error:
            STATS["errors"] += 1
            m = ERROR_RE.match(text)
            if not (m and m.group("code") in CODES):
                FAILURES.append(f"{tool}({str(args)[:120]}) → {text[:200]}")
            assert m and m.group("code") in CODES, f"{tool}({str(args)[:200]}) → unstructured: {text[:300]}"
        else:
            assert structured is not None and "sim_time" in structured, f"{tool}: answered without sim_time"
        return is_error, text, structured

    @rule()
    def spawn(self) -> None:
        name = f"r{self.robots + 1}"
        is_error, _, _ = self.call("spawn_robot", {"name": name, "x": -4.0 + 1.5 * self.robots, "y": -3.0},
                                   hostile=False)
        self.robots += 0 if is_error else 1

    @rule(steps=st.integers(1, 40))
    def step(self, steps: int) -> None:
        t0 = HostileMCP.svc.sim_time
        is_error, text, out = self.call("step_simulation", {"steps": steps}, hostile=False)
        assert not is_error, text
        assert math.isclose(out["sim_time"], t0 + steps / 100.0, abs_tol=1e-9), (t0, steps, out["sim_time"])

    @rule(x=st.floats(-3, 3), y=st.floats(-3, 3))
    def navigate(self, x: float, y: float) -> None:
        self.call("navigate_to", {"robot": "r1", "x": x, "y": y}, hostile=False)

    @rule()
    def look(self) -> None:
        self.call("list_robots", {"response_format": "normal"}, hostile=False)

    def attack(self, tool: str, data: st.DataObject) -> None:
        fields, base = TARGETS[tool]
        field = data.draw(st.sampled_from(fields), label="field")
        value = data.draw(st.sampled_from(HOSTILE), label="value")
        self.call(tool, {**base, field: value}, hostile=True)

    # two rules: hostile calls are about half of all steps
    @rule(tool=st.sampled_from(sorted(TARGETS)), data=st.data())
    def hostile(self, tool: str, data: st.DataObject) -> None:
        self.attack(tool, data)

    @rule(tool=st.sampled_from(sorted(TARGETS)), data=st.data())
    def hostile_again(self, tool: str, data: st.DataObject) -> None:
        self.attack(tool, data)

    @invariant()
    def alive(self) -> None:
        h = HostileMCP.svc.sim_health()
        assert h["alive"] and h["dead_reason"] is None, h
        assert h["command_errors"] == 0, h["recent_errors"]


@pytest.fixture(scope="module")
def machine_env(tmp_path_factory: pytest.TempPathFactory) -> Any:
    ws = tmp_path_factory.mktemp("machine")
    os.symlink(SECRET_DIR, ws / "link")  # a symlink out of the workspace
    svc = FleetService(FleetConfig(world="empty", seed=7, workspace=str(ws)))
    svc.start("paused")
    yield svc, build_server(svc)
    svc.close()


def test_hostile_state_machine(machine_env: Any) -> None:
    HostileMCP.svc, HostileMCP.server = machine_env
    STATS.clear()
    FAILURES.clear()
    run_state_machine_as_test(HostileMCP, settings=settings(
        max_examples=12, stateful_step_count=25, derandomize=True, database=None, deadline=None,
        phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck)))  # no shrinking: bounded
    print(f"\nhostile state machine: {dict(STATS)}; failures: {len(FAILURES)}")
    assert STATS["hostile"] > 80 and not FAILURES
