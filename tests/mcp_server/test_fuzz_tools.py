"""Every tool called with Hypothesis-generated arguments from its own input schema: it answers (with sim time)
or fails with a structured error carrying a known code (never INTERNAL, never the SDK's bare "Error executing
tool"), and the world still steps afterwards."""

from __future__ import annotations

import asyncio
from typing import Any

import anyio
import pytest
from hypothesis import HealthCheck, given, settings
from mcp.client import Client
from mcp.server.mcpserver import MCPServer

from fleet import FleetConfig, FleetService
from mcp_server.server import build_server
from sim import Pose2D
from tests.mcp_server.helpers import ERROR_RE, text_of
from tests.mcp_server.schema_strategies import from_schema


def _schemas() -> dict[str, dict[str, Any]]:
    svc = FleetService(FleetConfig(world="empty"))
    try:
        tools = asyncio.run(build_server(svc).list_tools())
        return {t.name: t.input_schema for t in tools}
    finally:
        svc.close()


SCHEMAS = _schemas()
CODES = {"UNKNOWN_ROBOT", "UNKNOWN_MODEL", "INVALID_ARGUMENT", "INVALID_CONFIG", "PLANNING_FAILED", "COLLISION",
         "OUT_OF_BOUNDS", "PATH_NOT_ALLOWED", "LIMIT_EXCEEDED", "ESTOPPED", "LEASE_HELD", "PHYSICS_UNSTABLE",
         "NOT_FOUND", "UNSUPPORTED", "BUSY", "TIMEOUT"}  # every ErrorCode but INTERNAL
# sim/world_models.physics_properties fails with KeyError 'gravity' on pybullet 3.2.7 (reported): these tools
# end in an unexpected error for every input until sim is fixed.


async def _call(server: MCPServer, tool: str, args: dict[str, Any]) -> tuple[bool, str, Any]:
    async with Client(server) as c:
        r = await c.call_tool(tool, args)
        return r.is_error, text_of(r), r.structured_content


def _prepare(svc: FleetService) -> None:
    svc.reset()
    svc.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    svc.spawn_robot("r2", Pose2D(2.0, 0.0, 0.0))
    svc.navigate("r2", Pose2D(3.0, 1.0, 0.0))  # a task t<n> exists (ids are global: t1 may be older)
    svc.step(5)


def _check(tool: str, args: dict[str, Any], outcome: tuple[bool, str, Any]) -> None:
    is_error, text, structured = outcome
    if is_error:
        m = ERROR_RE.match(text)
        assert m and m.group("code") in CODES, f"{tool}({args}) → unstructured error: {text[:300]}"
    else:
        assert structured is not None and "sim_time" in structured, f"{tool}({args}) answered without sim_time"


@pytest.fixture(scope="module")
def fuzz_env(tmp_path_factory: pytest.TempPathFactory) -> Any:
    svc = FleetService(FleetConfig(world="empty", seed=5, workspace=str(tmp_path_factory.mktemp("fuzz"))))
    yield svc, build_server(svc)
    svc.close()




@pytest.mark.parametrize("tool", sorted(SCHEMAS))
def test_generated_arguments_get_an_answer_or_a_structured_error(tool: str, fuzz_env: Any) -> None:
    svc, server = fuzz_env
    _prepare(svc)

    @settings(max_examples=6, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(args=from_schema(SCHEMAS[tool]))
    def call(args: dict[str, Any]) -> None:
        _check(tool, args, anyio.run(_call, server, tool, args))

    call()
    # junk of the wrong type in every field: rejected by the schema, with the code
    junk = {k: {"junk": [1]} for k in SCHEMAS[tool].get("properties", {})}
    if junk:
        is_error, text, _ = anyio.run(_call, server, tool, junk)
        assert is_error and text.startswith("INVALID_ARGUMENT: "), f"{tool}: {text[:200]}"
    # the world still steps
    before = svc.world.step_count
    svc.step(3)
    assert svc.world.step_count == before + 3
