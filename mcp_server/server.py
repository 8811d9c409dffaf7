"""Build the fleetnav MCP server: thin typed tools over one FleetService built at startup."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

from mcp.server.mcpserver import MCPServer

from fleet import FleetService
from mcp_server.app import App
from mcp_server.registry import ToolRegistrar
from mcp_server.tools import TOOL_GROUPS

INSTRUCTIONS = """fleetnav runs a real PyBullet world with differential-drive robots. Every tool acts in the simulation
and reports what happened with the sim time; errors carry a code and a hint for what to do next. Long actions
(navigate, follow_waypoints, cover_area, missions) return an id at once: poll its status. Start with
sim_status and list_robots."""


def build_server(service: FleetService | Callable[[], FleetService], *, read_only: bool = False,
                 name: str = "fleetnav") -> MCPServer:
    """The MCP server over `service` (or a factory called at startup). In read-only mode only non-mutating
    tools are exposed."""
    holder: dict[str, FleetService] = {}

    @asynccontextmanager
    async def lifespan(_: MCPServer) -> AsyncIterator[App]:
        if "svc" not in holder:
            holder["svc"] = service if isinstance(service, FleetService) else service()
        yield App(holder["svc"], read_only=read_only)

    server = MCPServer(name=name, instructions=INSTRUCTIONS, lifespan=lifespan)
    registrar = ToolRegistrar(server, read_only, [])
    for register in TOOL_GROUPS:
        register(registrar)
    server.fleetnav_tools = registrar.registered  # type: ignore[attr-defined]
    return server
