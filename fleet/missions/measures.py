"""Figures computed from a run's recorded data: time to a goal, swept coverage, the BARN score."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from shapely.geometry import LineString, Point, Polygon
from shapely.ops import unary_union

from fleet.missions.types import RunData
from fleet.tasks.base import pose_param
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D


def first_within(traj: np.ndarray | None, x: float, y: float, tol: float) -> tuple[float | None, float]:
    """(first time the robot was within `tol` of (x, y), or None; the closest it came)."""
    if traj is None or not len(traj):
        return None, math.inf
    d = np.hypot(traj[:, 1] - x, traj[:, 2] - y)
    hit = np.flatnonzero(d <= tol)
    return (float(traj[hit[0], 0]) if len(hit) else None), float(d.min())


def swept_coverage(trajs: Sequence[np.ndarray], polygon: Sequence[Sequence[float]],
                   holes: Sequence[Sequence[Sequence[float]]], tool_width: float) -> float:
    """Percent of the region (polygon minus holes) swept by a disc tool of `tool_width` along the paths."""
    region = Polygon(polygon, holes)
    swept = []
    for tr in trajs:
        if len(tr) >= 2:
            swept.append(LineString(tr[:, 1:3]).buffer(tool_width / 2))
        elif len(tr) == 1:
            swept.append(Point(tr[0, 1], tr[0, 2]).buffer(tool_width / 2))
    if not swept or region.area <= 0:
        return 0.0
    return 100.0 * unary_union(swept).intersection(region).area / region.area


def task_goal(data: RunData, key: str) -> Pose2D:
    rec = data.tasks.get(key)
    if rec is None:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"no task '{key}'", f"tasks: {', '.join(data.tasks) or 'none'}")
    return pose_param(rec.params)


def pose_at(traj: np.ndarray, t: float) -> Pose2D:
    i = int(np.clip(np.searchsorted(traj[:, 0], t), 0, len(traj) - 1))
    return Pose2D(float(traj[i, 1]), float(traj[i, 2]), float(traj[i, 3]))


def barn(data: RunData, robot: str, key: str) -> tuple[float, float, float]:
    """(score, T, T_opt): success × T_opt / clip(T, 2·T_opt, 8·T_opt), T_opt = optimal length / v_max.

    The optimal length is an any-angle (Theta*) path on the static costmap from where the robot was when
    the task started to the task's goal; T is the task's duration (its start to its success)."""
    rec = data.tasks[key]
    traj = data.traj.get(robot)
    if rec.started is None or traj is None or not len(traj) or data.optimal_length is None:
        return 0.0, math.nan, math.nan
    start, goal = pose_at(traj, rec.started), pose_param(rec.params)
    t_opt = data.optimal_length(robot, start, goal) / data.v_max[robot]
    if rec.state != "succeeded" or rec.finished is None:
        return 0.0, math.nan, t_opt
    t = rec.finished - rec.started
    return t_opt / min(max(t, 2 * t_opt), 8 * t_opt), t, t_opt
