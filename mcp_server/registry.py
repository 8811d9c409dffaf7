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

    def __call__(self, *, read_only: bool, destructive: bool = False, idempotent: bool = False,
                 title: str | None = None) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        """Decorator: register an async tool unless the server is read-only and the tool mutates."""

        def deco(fn: Callable[..., Any]) -> Callable[..., Any]:
            if self.read_only_mode and not read_only:
                return fn
            ann = ToolAnnotations(title=title, read_only_hint=read_only, destructive_hint=destructive if not read_only
                                  else None, idempotent_hint=idempotent, open_world_hint=False)
            self.server.add_tool(compact(fleet_errors(fn)), annotations=ann)
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
