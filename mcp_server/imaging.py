"""Images as MCP image content (PNG) next to structured metadata the assistant can compute with."""

from __future__ import annotations

import numpy as np
from mcp.server.mcpserver import Image
from mcp_types import CallToolResult, TextContent
from PIL import Image as PILImage

from mcp_server.shaping import Answer
from sim.perception.drawing import base_image, to_png
from sim.types import CameraImage


def image_result(png: bytes, meta: Answer) -> CallToolResult:
    """The PNG as image content, the metadata as compact JSON text and as structured content."""
    return CallToolResult(content=[Image(data=png, format="png").to_image_content(),
                                   TextContent(type="text", text=meta.model_dump_json())],
                          structured_content=meta.model_dump(mode="json"))


def camera_png(image: CameraImage, which: str) -> bytes:
    """RGB as is; depth as grey (near = bright, no return = black) — the metadata carries the range."""
    if which == "depth":
        d = np.asarray(image.depth, dtype=float)
        ok = np.isfinite(d)
        grey = np.zeros(d.shape, dtype=np.uint8)
        if ok.any():
            lo, hi = float(d[ok].min()), float(d[ok].max())
            grey[ok] = (40 + 215 * (1 - (d[ok] - lo) / max(hi - lo, 1e-9))).astype(np.uint8)
        return to_png(PILImage.fromarray(grey, "L"))
    return to_png(base_image(image))


def depth_stats(image: CameraImage) -> dict[str, float | None]:
    """Range statistics, m, and `centre`: the median of the 5×5 patch at the image centre (straight ahead)."""
    d = np.asarray(image.depth, dtype=float) if image.depth is not None else np.zeros((0, 0))
    ok = d[np.isfinite(d)]
    if not ok.size:
        return {"min": None, "median": None, "max": None, "centre": None, "valid_fraction": 0.0}
    h, w = d.shape
    patch = d[h // 2 - 2:h // 2 + 3, w // 2 - 2:w // 2 + 3]
    patch = patch[np.isfinite(patch)]
    return {"min": round(float(ok.min()), 4), "median": round(float(np.median(ok)), 4),
            "max": round(float(ok.max()), 4), "centre": round(float(np.median(patch)), 4) if patch.size else None,
            "valid_fraction": round(ok.size / d.size, 4)}
