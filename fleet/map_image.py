"""The live view as a PNG: the map (static grid or a robot's costmap), robots, goals and debug markers, north
up, with the metadata needed to turn a pixel back into map coordinates."""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from typing import Any

from PIL import Image, ImageDraw

from fleet.markers import DebugMarker
from planning import LayeredCostmap, OccupancyGrid, render_map
from sim.types import Pose2D


def map_png(source: OccupancyGrid | LayeredCostmap, *, robots: Sequence[tuple[str, Pose2D]] = (),
            goals: Sequence[Pose2D] = (), markers: Sequence[DebugMarker] = (), robot_radius: float | None = None,
            max_px: int = 800) -> tuple[bytes, dict[str, Any]]:
    """PNG bytes and {width, height, metres_per_pixel, origin (map position of the image's lower-left corner),
    bounds}; the image is scaled down so its larger side is at most `max_px`."""
    grid = source.grid if isinstance(source, LayeredCostmap) else source
    scale = max(1, min(4, max_px // max(grid.width, grid.height)))
    img = render_map(source, robots=robots, goals=goals, scale=scale, robot_radius=robot_radius)
    px_per_m = scale / grid.resolution
    if max(img.size) > max_px:  # a big world: shrink (obstacles stay visible as grey)
        f = max_px / max(img.size)
        img = img.resize((max(1, round(img.width * f)), max(1, round(img.height * f))), Image.Resampling.BOX)
        px_per_m *= f
    xmin, ymin, xmax, ymax = grid.bounds
    draw_markers(img, markers, origin=(xmin, ymax), px_per_m=px_per_m)
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    meta = {"width": img.width, "height": img.height, "metres_per_pixel": round(1.0 / px_per_m, 5),
            "origin": [round(xmin, 4), round(ymin, 4)], "bounds": [round(v, 4) for v in (xmin, ymin, xmax, ymax)],
            "orientation": "north up: +x right, +y up; pixel (0, 0) is the top-left corner"}
    return buf.getvalue(), meta


def draw_markers(img: Image.Image, markers: Sequence[DebugMarker], *, origin: tuple[float, float],
                 px_per_m: float) -> None:
    """Draw markers on an image whose top-left pixel corner is the map point `origin` (xmin, ymax)."""
    draw = ImageDraw.Draw(img)

    def px(p: tuple[float, float]) -> tuple[float, float]:
        return ((p[0] - origin[0]) * px_per_m, (origin[1] - p[1]) * px_per_m)

    for m in markers:
        width = max(1, round(m.size * px_per_m))
        pts = [px(p) for p in m.points]
        c = m.colour
        if m.kind in ("point", "circle"):
            (x, y), r = pts[0], max(2.0, m.size * px_per_m)
            draw.ellipse([x - r, y - r, x + r, y + r], fill=c if m.kind == "point" else None,
                         outline=c, width=1 if m.kind == "point" else max(1, width // 4 or 1))
        elif m.kind in ("line", "path"):
            draw.line(pts, fill=c, width=width)
        elif m.kind == "arrow":
            draw.line(pts, fill=c, width=width)
            (x0, y0), (x1, y1) = pts
            a, head = math.atan2(y1 - y0, x1 - x0), max(6.0, 3 * width)
            for s in (-1, 1):
                draw.line([(x1, y1), (x1 - head * math.cos(a + s * 0.45), y1 - head * math.sin(a + s * 0.45))],
                          fill=c, width=width)
        elif m.kind == "box":
            (x0, y0), (x1, y1) = pts
            draw.rectangle([min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)], outline=c, width=width)
        elif m.kind == "polygon":
            draw.polygon(pts, outline=c, width=width)
        if m.text:
            x, y = pts[0]
            draw.text((x + 3, y - 12), m.text, fill=c)
