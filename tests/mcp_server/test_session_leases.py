"""When an MCP session ends (the client closes it), its leases are released and its robots stop; another
session's leases stay. Over the SDK's in-memory client (the server unwinds the connection's exit stack when the
session ends; `mode="legacy"` is the session handshake stdio and streamable HTTP with sessions use)."""

from __future__ import annotations

import pytest
from mcp.client import Client
from mcp.server.mcpserver import MCPServer

from fleet import FleetService
from sim import Pose2D
from tests.fleet.zenoh_util import wait_until
from tests.mcp_server.helpers import err, ok


@pytest.mark.anyio
async def test_closing_a_session_releases_its_leases_and_stops_its_robots(server: MCPServer,
                                                                          service: FleetService) -> None:
    service.reset()
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.spawn_robot("r2", Pose2D(3, 0, 0))
    async with Client(server, mode="legacy") as keeper:
        await ok(keeper, "acquire_lease", {"robot": "r2"})
        async with Client(server, mode="legacy") as a:
            await ok(a, "acquire_lease", {"robot": "r1"})
            await ok(a, "drive_robot", {"robot": "r1", "v": 0.3, "w": 0.0, "duration": 30.0, "wait": False})
            holder = service.safety.holder("r1")
            assert holder is not None and holder.startswith("mcp/s")
            await err(keeper, "drive_robot", {"robot": "r1", "v": 0.1, "w": 0.0, "wait": False}, "LEASE_HELD")
        wait_until(lambda: service.safety.holder("r1") is None, timeout=10, what="r1's lease to go")
        assert "r1" not in service.safety.manual  # its manual command is gone: it stops
        lost = [e for e in service.events.since(0) if e.kind == "client_lost"]
        assert lost and lost[-1].robots == ("r1",) and "session closed" in lost[-1].message
        assert service.safety.holder("r2") is not None  # the other session keeps its lease
        await ok(keeper, "drive_robot", {"robot": "r1", "v": 0.1, "w": 0.0, "wait": False})  # r1 is free now
    wait_until(lambda: service.safety.holder("r2") is None, timeout=10, what="r2's lease to go")

