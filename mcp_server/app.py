"""The typed context every tool reaches: the FleetService built once at startup, plus server settings."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from mcp.server.mcpserver import Context

if TYPE_CHECKING:
    from fleet import FleetService


@dataclass
class App:
    service: FleetService
    read_only: bool = False
    client_id: str = "mcp"  # the client id MCP commands act under (leases, rate limits)
    extras: dict[str, Any] = field(default_factory=dict)  # per-server state of tool groups (e.g. SLAM sessions)


def app_of(ctx: Context) -> App:
    app = ctx.request_context.lifespan_context
    assert isinstance(app, App), "the server was built without its lifespan"
    return app


async def run(ctx: Context, fn: Any, *args: Any, **kwargs: Any) -> Any:
    """Run a FleetService operation on the sim thread without blocking the event loop."""
    svc = app_of(ctx).service
    return await svc.acall(lambda: fn(*args, **kwargs))
