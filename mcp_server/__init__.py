"""mcp_server: the MCP front door — thin typed tools over one FleetService, response shaping, transports.

`build_server(service_or_factory, read_only=...)` returns the MCPServer (tools, resources, prompts);
`fleetnav serve` runs it over stdio or streamable HTTP. The tool reference is docs/mcp-tools.md."""

from mcp_server.app import App, app_of, run
from mcp_server.auth import StaticTokenVerifier, auth_settings, is_loopback
from mcp_server.server import FleetMCPServer, build_server

__all__ = ["App", "FleetMCPServer", "StaticTokenVerifier", "app_of", "auth_settings", "build_server", "is_loopback",
           "run"]
