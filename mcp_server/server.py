"""Build the fleetnav MCP server: thin typed tools over one FleetService built at startup."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from mcp.server.auth.provider import TokenVerifier
from mcp.server.auth.settings import AuthSettings
from mcp.server.mcpserver import Context, MCPServer
from mcp.server.mcpserver.exceptions import ToolError, UnexpectedToolError
from mcp_types import CallToolResult, InputRequiredResult
from pydantic import ValidationError

from fleet import FleetService
from mcp_server.app import App
from mcp_server.registry import ToolRegistrar
from mcp_server.resources import register_prompts, register_resources
from mcp_server.tools import CORE, TOOLSETS, parse_toolsets

INSTRUCTIONS = """fleetnav runs a real PyBullet world with differential-drive robots. Every tool acts in the simulation
and reports what happened with the sim time; errors carry a code and a hint for what to do next. Long actions
(navigate, follow_waypoints, cover_area, missions) return an id at once: poll its status. Start with
sim_status and list_robots."""


class FleetMCPServer(MCPServer):
    """MCPServer whose tool errors all start with their code: argument-validation errors become
    INVALID_ARGUMENT with a hint (the SDK's own text is a raw pydantic dump), FleetErrors lose the SDK's
    "Error executing tool" prefix, an unknown tool is NOT_FOUND."""

    fleetnav_service: Callable[[], FleetService] | None = None

    async def call_tool(self, name: str, arguments: dict[str, Any], context: Context[Any, Any] | None = None
                        ) -> CallToolResult | InputRequiredResult:
        try:
            return await super().call_tool(name, arguments, context)
        except ToolError as exc:
            cause = exc.__cause__
            if isinstance(cause, ValidationError) and not isinstance(exc, UnexpectedToolError):  # the arguments
                stamp = f" | sim_time: {self.fleetnav_service().sim_time:.3f}" if self.fleetnav_service else ""
                raise ToolError(invalid_arguments(name, cause) + stamp) from cause
            if isinstance(cause, ToolError) and isinstance(cause.__cause__, Exception):  # drop the SDK's prefix
                raise cause from cause.__cause__
            if str(exc).startswith("Unknown tool"):
                raise ToolError(f"NOT_FOUND: unknown tool '{name}' | hint: list the tools (tools/list)") from exc
            raise


def invalid_arguments(tool: str, exc: ValidationError) -> str:
    parts = []
    for err in exc.errors()[:5]:
        where = ".".join(str(p) for p in err["loc"]) or "arguments"
        got = repr(err.get("input"))
        parts.append(f"{where}: {err['msg']}" + (f" (got {got[:60]})" if err["type"] != "missing" else ""))
    return f"INVALID_ARGUMENT: {'; '.join(parts)} | hint: check the input schema of {tool}"


def server_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fleetnav")
    except PackageNotFoundError:  # running from a source tree without an install
        return "0.0.0+source"


def build_server(service: FleetService | Callable[[], FleetService], *, read_only: bool = False,
                 name: str = "fleetnav", start: bool | None = None, speed: float = 1.0,
                 token_verifier: TokenVerifier | None = None, auth: AuthSettings | None = None,
                 toolsets: str | tuple[str, ...] = ("all",)) -> MCPServer:
    """The MCP server over `service` (or a factory called at startup). In read-only mode only non-mutating
    tools are exposed. `start` runs the service's sim thread in real time × `speed` at startup (default: when
    built from a factory, i.e. service mode; an instance is left as it is, e.g. batch-stepped by tests).
    `token_verifier` + `auth` require bearer tokens on the HTTP transport. `toolsets` picks the tool groups
    (mcp_server.tools.TOOLSETS, plus `core` and `all`); `fleetnav serve` defaults to `core`."""
    holder: dict[str, FleetService] = {}
    run_thread = (not isinstance(service, FleetService)) if start is None else start

    def current() -> FleetService:
        if "svc" not in holder:
            holder["svc"] = service if isinstance(service, FleetService) else service()
            holder["svc"].read_only = read_only  # enforced by the service, not only by hiding tools
            if run_thread:
                holder["svc"].start("realtime", speed)
        return holder["svc"]

    @asynccontextmanager
    async def lifespan(_: MCPServer) -> AsyncIterator[App]:
        yield App(current(), read_only=read_only)

    server = FleetMCPServer(name=name, version=server_version(), instructions=INSTRUCTIONS, lifespan=lifespan,
                            token_verifier=token_verifier, auth=auth)
    registrar = ToolRegistrar(server, read_only, [], parse_toolsets(toolsets), CORE)
    for group, register in TOOLSETS.items():
        registrar.group = group
        register(registrar)
    register_resources(server, current)
    register_prompts(server)
    server.fleetnav_tools = registrar.registered  # type: ignore[attr-defined]
    server.fleetnav_service = current
    return server
