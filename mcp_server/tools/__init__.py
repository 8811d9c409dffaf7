"""Tool groups; each module's `register(tool)` adds its tools."""

from mcp_server.tools import sim

TOOL_GROUPS = [sim.register]
