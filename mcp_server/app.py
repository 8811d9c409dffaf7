"""The typed context every tool reaches: the FleetService built once at startup, plus server settings."""

from __future__ import annotations

import itertools
import logging
import weakref
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from mcp.server.mcpserver import Context

if TYPE_CHECKING:
    from fleet import FleetService


@dataclass
class App:
    service: FleetService
    read_only: bool = False
    client_id: str = "mcp"  # prefix of the per-session client ids MCP commands act under (leases, rate limits)
    extras: dict[str, Any] = field(default_factory=dict)  # per-server state of tool groups (e.g. SLAM sessions)


_SESSIONS: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
_COUNTER = itertools.count(1)
log = logging.getLogger("fleetnav.mcp")


def app_of(ctx: Context) -> App:
    app = ctx.request_context.lifespan_context
    assert isinstance(app, App), "the server was built without its lifespan"
    return app


def client_of(ctx: Context) -> str:
    """The client id this MCP caller acts under (leases, rate limits), so one client cannot drive, navigate
    or release another's leased robot:

    - the bearer token's identity on authenticated HTTP, as the prefix;
    - a session handshake (stdio, streamable HTTP with a session): one id per session (`/s<n>`);
    - the stateless 2026 protocol has no session: the client's declared name (`/c:<name>`) when it sent one,
      else the prefix alone (give each client its own token to separate them).
    """
    from mcp.server.auth.middleware.auth_context import get_access_token
    from mcp_types.version import MODERN_PROTOCOL_VERSIONS

    token = get_access_token()
    who = token.client_id if token is not None else app_of(ctx).client_id
    conn = getattr(ctx.request_context.session, "_connection", None)
    if conn is None:
        return who
    if conn.protocol_version in MODERN_PROTOCOL_VERSIONS:  # stateless: a new connection per request
        params = conn.client_params
        name = params.client_info.name if params is not None and params.client_info is not None else ""
        return f"{who}/c:{name[:40]}" if name else who
    sid = _SESSIONS.get(conn)
    if sid is None:
        sid = _SESSIONS[conn] = f"s{next(_COUNTER)}"
        stack = getattr(conn, "exit_stack", None)
        if stack is not None:  # the SDK unwinds it when the session ends (client closed, stdio EOF, HTTP DELETE)
            stack.push_async_callback(_release, app_of(ctx).service, f"{who}/{sid}")
    return f"{who}/{sid}"


async def _release(service: FleetService, client: str) -> None:
    """The session ended: its leases go and its robots stop (nobody is left to drive them)."""
    import anyio

    try:
        robots = await anyio.to_thread.run_sync(service.release_client, client, "MCP session closed")
    except Exception as exc:  # the service is shutting down (or dead): nothing left to release into
        log.info("releasing %s at session end: %s", client, exc)
        return
    if robots:
        log.info("MCP session %s closed: released %s", client, ", ".join(robots))


async def run(ctx: Context, fn: Any, *args: Any, **kwargs: Any) -> Any:
    """Run a FleetService operation on the sim thread without blocking the event loop."""
    svc = app_of(ctx).service
    return await svc.acall(lambda: fn(*args, **kwargs))
