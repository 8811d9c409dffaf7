"""`fleetnav serve`: the MCP server over a FleetService running in real time.

stdio by default (for an assistant that launches it); `--transport http` serves streamable HTTP on
127.0.0.1. Binding anywhere else requires a bearer token (`--token` or FLEETNAV_MCP_TOKEN). File arguments
are confined to `--workspace`. Exit codes: 0 clean shutdown, 2 bad input.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import typer

EXIT_INPUT = 2


def serve(
    transport: str = typer.Option("stdio", "--transport", help="stdio or http (streamable HTTP)"),
    host: str = typer.Option("127.0.0.1", "--host", help="http: interface to bind (non-loopback needs --token)"),
    port: int = typer.Option(8000, "--port", min=0, max=65535, help="http: port"),
    path: str = typer.Option("/mcp", "--path", help="http: endpoint path"),
    token: str | None = typer.Option(None, "--token", envvar="FLEETNAV_MCP_TOKEN",
                                     help="http: bearer token clients must send (≥ 16 characters)"),
    world: str = typer.Option("robot_arena", "--world", help="a shipped world name or an SDF file"),
    workspace: Path | None = typer.Option(None, "--workspace", help="the only directory file arguments may read "
                                          "(writes: its outputs/); default ~/.local/share/fleetnav/workspace"),
    seed: int = typer.Option(0, "--seed"),
    fidelity: str = typer.Option("kinematic", "--fidelity", help="kinematic or dynamic"),
    speed: float = typer.Option(1.0, "--speed", min=0.01, max=1000, help="real-time factor of the clock"),
    read_only: bool = typer.Option(False, "--read-only", help="expose only tools that change nothing"),
    live: bool = typer.Option(False, "--live", help="also serve a Foxglove WebSocket live view"),
    live_port: int = typer.Option(8765, "--live-port"),
    toolsets: str = typer.Option("core", "--toolsets", help="tool groups to expose: core (default, ≤ 30 tools), all, "
                                 "or any of sim,world,robots,sensors,nav,fleet,slam,perception,debug,records,"
                                 "missions,challenges (comma-separated)"),
) -> None:
    """Serve the fleet to AI assistants over MCP (stdio, or streamable HTTP)."""
    if transport not in ("stdio", "http"):
        _fail(f"--transport must be stdio or http, got '{transport}'")
    if fidelity not in ("kinematic", "dynamic"):
        _fail(f"--fidelity must be kinematic or dynamic, got '{fidelity}'")
    if workspace is not None and not workspace.is_dir():
        _fail(f"--workspace {workspace} is not a directory")
    from mcp_server.tools import parse_toolsets
    from sim.errors import FleetError

    try:
        parse_toolsets(toolsets)
    except FleetError as exc:
        _fail(f"--toolsets: {exc.message} ({exc.hint})")
    from mcp_server.auth import MIN_TOKEN_CHARS, is_loopback

    if transport == "http" and not is_loopback(host) and not token:
        _fail(f"binding to {host} exposes the fleet to the network: give --token (or FLEETNAV_MCP_TOKEN)")
    if token is not None and len(token) < MIN_TOKEN_CHARS:
        _fail(f"the token must have at least {MIN_TOKEN_CHARS} characters")
    if transport == "stdio":
        _protect_stdout()
    raise typer.Exit(_run(transport, host, port, path, token, world, workspace, seed, fidelity, speed, read_only,
                          live, live_port, toolsets))


def _run(transport: str, host: str, port: int, path: str, token: str | None, world: str, workspace: Path | None,
         seed: int, fidelity: str, speed: float, read_only: bool, live: bool, live_port: int,
         toolsets: str = "core") -> int:
    import anyio

    from fleet import FleetConfig, FleetService
    from mcp_server.auth import StaticTokenVerifier, auth_settings
    from mcp_server.server import build_server
    from sim.errors import FleetError

    built: list[Any] = []
    try:  # built before serving, so a bad world fails with one clear line instead of a dead server
        svc = FleetService(FleetConfig(world=world, seed=seed, fidelity=fidelity,
                                       workspace=str(workspace.resolve()) if workspace is not None else None))
    except FleetError as exc:
        _fail(f"{exc.code.value}: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""))
    built.append(svc)
    if live:
        from fleet.live_view import LiveView

        built.append(LiveView(port=live_port).attach(svc))
    kw: dict[str, Any] = {}
    if token:
        kw = {"token_verifier": StaticTokenVerifier(token), "auth": auth_settings(host, port)}
    server = build_server(lambda: svc, read_only=read_only, start=True, speed=speed, toolsets=toolsets, **kw)
    try:
        if transport == "stdio":
            anyio.run(server.run_stdio_async)
        else:
            anyio.run(lambda: server.run_streamable_http_async(host=host, port=port, streamable_http_path=path))
    except KeyboardInterrupt:
        pass
    finally:
        for obj in reversed(built):
            obj.close()
    return 0


def _protect_stdout() -> None:
    """stdio carries JSON-RPC: route anything native code prints to fd 1 to stderr instead, and give Python's
    sys.stdout (which the MCP transport writes to) the real stdout."""
    real = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = os.fdopen(real, "w", encoding="utf-8", buffering=1)


def _fail(message: str) -> None:
    typer.echo(f"fleetnav serve: {message}", err=True)
    raise typer.Exit(EXIT_INPUT)


def register(app: typer.Typer) -> None:
    app.command()(serve)
