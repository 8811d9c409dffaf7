"""Registering tools: annotations (read-only vs destructive) and read-only mode in one place."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mcp.server.mcpserver import MCPServer
from mcp_types import CallToolResult, TextContent, ToolAnnotations
from pydantic import BaseModel

from mcp_server.errors import fleet_errors


@dataclass
class ToolRegistrar:
    server: MCPServer
    read_only_mode: bool
    registered: list[str]
    toolsets: frozenset[str] = frozenset({"all"})
    core: frozenset[str] = frozenset()
    group: str = ""  # the toolset whose module is registering now

    def wanted(self, name: str) -> bool:
        return "all" in self.toolsets or self.group in self.toolsets or ("core" in self.toolsets and name in self.core)

    def __call__(self, *, read_only: bool, destructive: bool = False, idempotent: bool = False,
                 title: str | None = None) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        """Decorator: register an async tool unless the server is read-only and the tool mutates."""

        def deco(fn: Callable[..., Any]) -> Callable[..., Any]:
            if (self.read_only_mode and not read_only) or not self.wanted(fn.__name__):
                return fn
            ann = ToolAnnotations(title=title, read_only_hint=read_only, destructive_hint=destructive if not read_only
                                  else None, idempotent_hint=idempotent, open_world_hint=False)
            self.server.add_tool(compact(fleet_errors(fn)), annotations=ann)
            describe_parameters(self.server, fn.__name__)
            self.registered.append(fn.__name__)
            return fn

        return deco


def compact(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Answer a pydantic model as compact JSON text plus the same structured content (the SDK's default
    text is indented, which roughly doubles the tokens an assistant reads). Other results pass through."""

    @functools.wraps(fn)
    async def wrapper(*args: Any, **kwargs: Any) -> Any:
        out = await fn(*args, **kwargs)
        if isinstance(out, BaseModel) and not isinstance(out, CallToolResult):
            return CallToolResult(content=[TextContent(type="text", text=out.model_dump_json())],
                                  structured_content=out.model_dump(mode="json"))
        return out

    return wrapper


# Descriptions for parameters that recur across tools (a tool's own Field description wins).
COMMON = {
    "robot": "robot name (list_robots shows them)", "name": "name of the robot, model or item",
    "x": "x in the world (map) frame, m", "y": "y in the world (map) frame, m",
    "yaw": "heading, rad (counter-clockwise from +x)", "z": "height, m",
    "response_format": "summary (smallest), normal, or full", "task_id": "task id from the tool that started it",
    "planner": "global planner (navigation_options lists them)", "controller": "path tracking controller",
    "model": "robot model name (configs/robots) or a .yaml path in the workspace",
    "fidelity": "kinematic (fast) or dynamic (full physics)", "limit": "at most this many rows",
    "offset": "skip this many rows (paging)", "robots": "robot names; omitted: all", "polygon": "[[x, y], ...] m",
    "pose": "pose in the world frame (m, rad)", "path": "file path (reads: workspace; writes: its outputs/ area)",
    "file": "file path inside the workspace", "xml": "SDF or URDF XML text", "static": "never moves",
    "config": "settings of that service (its fields; unknown keys are an error)", "params": "task parameters",
    "kind": "filter by kind", "sensor": "sensor name", "seed": "random seed", "reason": "why (kept in events)",
    "timeout_s": "sim seconds at most", "max_px": "image size, pixels", "directory": "folder in the workspace",
    "behaviour_id": "behaviour id from start_behaviour", "marker_id": "marker id from add_marker",
    "job_id": "job id from run_mission / run_challenge", "map_name": "a loaded map's name (list_maps)",
    "ns": "marker namespace", "since_seq": "events after this sequence number",
    "type": "type name (listed by the matching *_options/*_types tool)", "options": "method options",
    "method": "allocation method", "dry_run": "plan only, change nothing", "count": "how many",
    "mode": "how to run", "duration": "sim seconds", "show": "also draw it as a debug marker",
}


def describe_parameters(server: MCPServer, tool: str) -> None:
    """Give every top-level parameter of `tool` a description (the common one for its name, else one built
    from its name), so no parameter reaches the assistant undocumented."""
    t = server._tool_manager.get_tool(tool)
    if t is None:
        return
    for pname, prop in t.parameters.get("properties", {}).items():
        if isinstance(prop, dict) and not prop.get("description"):
            prop["description"] = COMMON.get(pname, pname.replace("_", " "))
    _untitle(t.parameters)
    if t.fn_metadata.output_schema is not None:
        _untitle(t.fn_metadata.output_schema)


def _untitle(schema: Any) -> None:
    """Drop pydantic's generated `title`s (a field's name again, title-cased): about a fifth of tools/list."""
    if isinstance(schema, dict):
        if isinstance(schema.get("title"), str):
            del schema["title"]
        for key, v in schema.items():
            if key in ("properties", "$defs") and isinstance(v, dict):
                for sub in v.values():
                    _untitle(sub)
            else:
                _untitle(v)
    elif isinstance(schema, list):
        for v in schema:
            _untitle(v)
