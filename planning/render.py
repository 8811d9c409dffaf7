"""PNG images of grids and costmaps with robots, paths and goals drawn on top (Pillow)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from planning.costmap import LayeredCostmap
from planning.grid import OccupancyGrid
from sim.types import Pose2D

PATH_COLOURS = [(220, 40, 40), (30, 120, 220), (30, 160, 60), (230, 140, 0), (150, 60, 200), (0, 170, 170)]
RobotMark = Pose2D | tuple[str, Pose2D]


def render_map(source: OccupancyGrid | LayeredCostmap, *, robots: Sequence[RobotMark] = (),
               paths: Sequence[np.ndarray] = (), goals: Sequence[Pose2D] = (), scale: int = 2,
               robot_radius: float | None = None) -> Image.Image:
    """An RGB image, north up: obstacles black, unknown grey, inflation in blue shades, keep-outs red.

    `scale` is pixels per cell. Robots are circles with a heading tick (radius from the costmap unless
    given), goals are crosses, paths are polylines with a dot per vertex, in a colour per path.
    """
    if scale < 1:
        scale = 1
    grid = source.grid if isinstance(source, LayeredCostmap) else source
    rgb = _base_colours(source)
    img = Image.fromarray(np.ascontiguousarray(np.flipud(rgb)), mode="RGB")
    if scale > 1:
        img = img.resize((img.width * scale, img.height * scale), Image.Resampling.NEAREST)
    draw = ImageDraw.Draw(img)
    px_per_m = scale / grid.resolution
    _, _, _, ymax = grid.bounds

    def to_px(x: float, y: float) -> tuple[float, float]:
        return ((x - grid.origin[0]) * px_per_m, (ymax - y) * px_per_m)

    for k, path in enumerate(paths):
        colour = PATH_COLOURS[k % len(PATH_COLOURS)]
        pts = [to_px(float(x), float(y)) for x, y in np.asarray(path).reshape(-1, 2)]
        if len(pts) > 1:
            draw.line(pts, fill=colour, width=max(1, scale))
        for px, py in pts:
            draw.ellipse([px - scale, py - scale, px + scale, py + scale], fill=colour)
    for goal in goals:
        gx, gy = to_px(goal.x, goal.y)
        s = 4 * scale
        draw.line([gx - s, gy - s, gx + s, gy + s], fill=(0, 150, 0), width=max(1, scale))
        draw.line([gx - s, gy + s, gx + s, gy - s], fill=(0, 150, 0), width=max(1, scale))
    radius = robot_radius if robot_radius is not None else getattr(source, "robot_radius", 0.25)
    for mark in robots:
        name, pose = (mark if isinstance(mark, tuple) else ("", mark))
        cx, cy = to_px(pose.x, pose.y)
        r = max(radius * px_per_m, 2.0)
        draw.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(255, 120, 0), width=max(1, scale))
        draw.line([cx, cy, cx + r * math.cos(pose.yaw), cy - r * math.sin(pose.yaw)], fill=(255, 120, 0),
                  width=max(1, scale))
        if name:
            draw.text((cx + r + 2, cy - r), name, fill=(120, 60, 0))
    return img


def save_png(image: Image.Image, path: str | Path) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    image.save(p, format="PNG")
    return p


def _base_colours(source: OccupancyGrid | LayeredCostmap) -> np.ndarray:
    if isinstance(source, OccupancyGrid):
        occ = np.clip(source.data.astype(float), 0, 100) / 100.0
        grey = (255 * (1.0 - occ)).astype(np.uint8)
        grey[source.unknown()] = 160
        return np.repeat(grey[..., None], 3, axis=2)
    costs = source.costs.astype(float)
    rgb = np.full((*costs.shape, 3), 255, dtype=np.uint8)
    inflated = (costs > 0) & (costs < 253)
    shade = (costs / 252.0)[inflated]
    rgb[inflated] = np.column_stack([255 - 150 * shade, 255 - 110 * shade, np.full(shade.shape, 255)]).astype(np.uint8)
    rgb[costs == 253] = (90, 90, 160)
    rgb[costs == 255] = (160, 160, 160)
    rgb[source.lethal_mask] = (0, 0, 0)
    rgb[source.keepout_mask & ~source.grid.occupied()] = (200, 40, 40)
    return rgb
