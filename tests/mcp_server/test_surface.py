"""The MCP surface an assistant sees: toolsets (a lean default, the full set on request), every parameter
described, a tools/list that fits a token budget (real o200k tokenizer), named server, ≤ 2 progress/s."""

from __future__ import annotations

from typing import Any

import pytest
from mcp.client import Client

from fleet import FleetService
from mcp_server.server import build_server
from mcp_server.tools import CORE, TOOLSETS, parse_toolsets
from sim import Pose2D
from sim.errors import FleetError
from tests.mcp_server.helpers import err, ok

MAX_DEFAULT_TOOLS, MAX_DEFAULT_TOKENS = 30, 8000


def _tokens(text: str) -> int:
    import bpe_openai

    return len(bpe_openai.get_encoding("o200k_base").encode(text))


async def _list(service: FleetService, toolsets: Any) -> tuple[list[Any], str]:
    async with Client(build_server(service, toolsets=toolsets)) as c:
        res = await c.list_tools()
        return res.tools, res.model_dump_json(by_alias=True, exclude_none=True)


@pytest.mark.anyio
async def test_the_default_toolset_is_lean_and_the_full_set_stays_available(service: FleetService) -> None:
    core, wire = await _list(service, "core")
    assert {t.name for t in core} == set(CORE) and len(core) <= MAX_DEFAULT_TOOLS
    assert _tokens(wire) <= MAX_DEFAULT_TOKENS, f"core tools/list is {_tokens(wire)} o200k tokens"
    everything, _ = await _list(service, "all")
    assert len(everything) > 100 and {t.name for t in core} < {t.name for t in everything}
    union: set[str] = set()
    for name in TOOLSETS:
        tools, _ = await _list(service, name)
        assert tools, name
        union |= {t.name for t in tools}
    assert union == {t.name for t in everything}, "every tool belongs to a toolset"
    slam, _ = await _list(service, "core,slam")
    assert {"start_slam", "navigate_to"} <= {t.name for t in slam}
    with pytest.raises(FleetError, match="unknown toolset 'bogus'"):
        parse_toolsets("core,bogus")


@pytest.mark.anyio
async def test_every_parameter_is_described_and_the_server_is_named(service: FleetService) -> None:
    tools, _ = await _list(service, "all")
    missing = [f"{t.name}.{p}" for t in tools for p, s in t.input_schema.get("properties", {}).items()
               if not s.get("description")]
    assert not missing, missing
    async with Client(build_server(service)) as c:
        info = c.initialize_result.server_info if hasattr(c, "initialize_result") else None
        if info is not None:
            assert info.name == "fleetnav" and info.version


def test_server_version_is_set(service: FleetService) -> None:
    assert build_server(service).version not in ("", None)


@pytest.mark.anyio
async def test_progress_is_rate_limited(client: Client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    stamps: list[float] = []

    async def on_progress(progress: float, total: float | None, message: str | None) -> None:
        stamps.append(progress)

    # a paused clock: the tool steps the world in chunks as fast as it can; notifications stay ≤ 2/s
    import time

    t0 = time.monotonic()
    r = await client.call_tool("drive_robot", {"robot": "r1", "v": 0.2, "w": 0.0, "duration": 30.0},
                               progress_callback=on_progress)
    elapsed = time.monotonic() - t0
    assert not r.is_error
    # 60 chunks of 0.5 s sim were stepped; a slower machine only raises the allowance (not a timing assert)
    assert 1 <= len(stamps) <= 2 * elapsed + 2, (len(stamps), elapsed)  # ≤ 2/s plus the final one


@pytest.mark.anyio
async def test_missions_and_challenges_resolve_by_name(client: Client) -> None:
    m = await ok(client, "validate_mission", {"path": "arena_navigation"})
    assert m["valid"] and m["path"].endswith("configs/missions/arena_navigation.yaml")
    text = await err(client, "validate_mission", {"path": "no_such_mission"}, "NOT_FOUND")
    assert "arena_navigation" in text  # lists the shipped ones
    await err(client, "validate_mission", {"path": "../../etc/passwd.yaml"}, "NOT_FOUND")
