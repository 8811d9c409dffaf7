"""The trajectory plot of a run (PNG): the map, each robot's driven path, goals, collisions, final poses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import ImageDraw

from fleet.missions.types import RunData
from fleet.tasks.base import pose_param
from planning.render import render_map, save_png
from sim.errors import FleetError
from sim.types import Pose2D

TARGET_PX = 800  # the longer side of the image, roughly
MAX_POINTS = 2000  # per path drawn (longer trajectories are thinned)


def save_plot(data: RunData, path: Path) -> Path | None:
    if data.grid is None:
        return None
    grid = data.grid
    scale = max(1, round(TARGET_PX / max(grid.data.shape)))
    paths = [tr[:: max(1, len(tr) // MAX_POINTS), 1:3] for tr in data.traj.values() if len(tr)]
    finals = [(n, Pose2D(*map(float, tr[-1, 1:4]))) for n, tr in data.traj.items() if len(tr)]
    img = render_map(grid, robots=finals, paths=paths, goals=_goals(data), scale=scale,
                     robot_radius=max(data.radius.values(), default=0.25))
    draw = ImageDraw.Draw(img)
    px_per_m = scale / grid.resolution
    ymax = grid.bounds[3]
    for c in data.collisions:  # a red ring where each collision began
        tr = data.traj.get(c["robot"])
        if tr is None or not len(tr):
            continue
        i = int(np.clip(np.searchsorted(tr[:, 0], c["t"]), 0, len(tr) - 1))
        cx, cy = (tr[i, 1] - grid.origin[0]) * px_per_m, (ymax - tr[i, 2]) * px_per_m
        r = 6 * scale
        draw.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(230, 0, 0), width=max(2, scale))
    return save_png(img, path)


def _goals(data: RunData) -> list[Pose2D]:
    goals = []
    for rec in data.tasks.values():
        if "goal" in rec.params:
            try:
                goals.append(pose_param(rec.params))
            except FleetError:
                continue  # not a pose: nothing to mark
    return goals
