"""Calling tools in tests: the structured answer of a success, the text of an error (checked for its code)."""

from __future__ import annotations

import base64
import io
import json
import re
from typing import Any

import numpy as np
from mcp.client import Client
from mcp_types import CallToolResult, TextContent
from PIL import Image

from sim.errors import ErrorCode

ERROR_RE = re.compile(r"^(?P<code>[A-Z_]+): .+")


def text_of(r: CallToolResult) -> str:
    return " ".join(c.text for c in r.content if isinstance(c, TextContent))


async def ok(client: Client, tool: str, args: dict[str, Any] | None = None, **kw: Any) -> dict[str, Any]:
    """Call a tool that must succeed; its structured content (which always carries sim_time)."""
    r = await client.call_tool(tool, args or {}, **kw)
    text = text_of(r)
    assert not r.is_error, f"{tool}({args}) failed: {text}"
    assert r.structured_content is not None, f"{tool} has no structured content"
    assert isinstance(r.structured_content.get("sim_time"), float | int), f"{tool}: no sim_time"
    json_text = [c.text for c in r.content if isinstance(c, TextContent)]
    assert json.loads(json_text[-1]) == r.structured_content, f"{tool}: text and structured content differ"
    return r.structured_content


async def err(client: Client, tool: str, args: dict[str, Any] | None = None, code: str | None = None) -> str:
    """Call a tool that must fail with a structured error: `CODE: message | hint: ...`."""
    r = await client.call_tool(tool, args or {})
    text = text_of(r)
    assert r.is_error, f"{tool}({args}) unexpectedly succeeded: {text[:300]}"
    m = ERROR_RE.match(text)
    assert m and m.group("code") in ErrorCode.__members__, f"{tool}: unstructured error: {text[:300]}"
    if code is not None:
        assert m.group("code") == code, f"{tool}: expected {code}, got {text[:300]}"
    return text


async def image(client: Client, tool: str, args: dict[str, Any]) -> tuple[np.ndarray, dict[str, Any]]:
    """Call an image tool: the decoded PNG as an array, and the structured metadata."""
    r = await client.call_tool(tool, args)
    assert not r.is_error, text_of(r)
    imgs = [c for c in r.content if c.type == "image"]
    assert len(imgs) == 1 and imgs[0].mime_type == "image/png"
    arr = np.asarray(Image.open(io.BytesIO(base64.b64decode(imgs[0].data))))
    assert r.structured_content is not None and "sim_time" in r.structured_content
    return arr, r.structured_content
