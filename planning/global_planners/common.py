"""What every global planner shares: endpoint checks with a clear reason, reachability, path geometry."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import label

from planning.types import Costmap, PlanResult
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

_EIGHT = np.ones((3, 3), dtype=bool)
_labels_cache: dict[int, tuple[int, np.ndarray]] = {}  # id(costmap) -> (version, labels)


def cell_of(costmap: Costmap, x: float, y: float) -> tuple[int, int]:
    xmin, ymin, _, _ = costmap.bounds
    return int(np.floor((y - ymin) / costmap.resolution)), int(np.floor((x - xmin) / costmap.resolution))


def centre_of(costmap: Costmap, row: int, col: int) -> tuple[float, float]:
    xmin, ymin, _, _ = costmap.bounds
    return (xmin + (col + 0.5) * costmap.resolution, ymin + (row + 0.5) * costmap.resolution)


def check_endpoint(costmap: Costmap, pose: Pose2D, what: str) -> tuple[int, int]:
    """The (row, col) of a start/goal, or PLANNING_FAILED saying why it cannot be planned from/to."""
    xmin, ymin, xmax, ymax = costmap.bounds
    if not (xmin <= pose.x < xmax and ymin <= pose.y < ymax):
        raise FleetError(ErrorCode.PLANNING_FAILED,
                         f"{what} ({pose.x:.2f}, {pose.y:.2f}) is outside the map "
                         f"[{xmin:.2f}, {xmax:.2f}] × [{ymin:.2f}, {ymax:.2f}]",
                         f"choose a {what} inside the map")
    if not costmap.is_free(pose.x, pose.y):
        clearance = costmap.clearance(pose.x, pose.y)
        raise FleetError(ErrorCode.PLANNING_FAILED,
                         f"{what} ({pose.x:.2f}, {pose.y:.2f}) is in collision: {clearance:.2f} m from the "
                         f"nearest obstacle, robot radius {costmap.robot_radius:.2f} m + padding "
                         f"{getattr(costmap, 'padding', 0.0):.3f} m",
                         f"move the {what} into free space (or clear the costmap if the obstacle is stale)")
    return cell_of(costmap, pose.x, pose.y)


def check_reachable(costmap: Costmap, s: tuple[int, int], g: tuple[int, int]) -> None:
    """PLANNING_FAILED when start and goal lie in different 8-connected free regions (no search needed)."""
    key = id(costmap)
    cached = _labels_cache.get(key)
    if cached is None or cached[0] != costmap.version:
        labels, _ = label(costmap.free_mask, structure=_EIGHT)
        if len(_labels_cache) > 16:
            _labels_cache.clear()
        cached = (costmap.version, labels)
        _labels_cache[key] = cached
    labels = cached[1]
    if labels[s] != labels[g]:
        raise FleetError(ErrorCode.PLANNING_FAILED,
                         "no path: the goal is enclosed (not connected to the start through free space "
                         f"for a robot of radius {costmap.robot_radius:.2f} m + padding "
                         f"{getattr(costmap, 'padding', 0.0):.3f} m)",
                         "pick a goal in the start's region, remove the blocking obstacle or keep-out zone, "
                         "clear the costmap, or plan for the exact footprint (planning.navfn.plan_path)")


def path_length(path: np.ndarray) -> float:
    return float(np.hypot(*np.diff(path, axis=0).T).sum()) if len(path) > 1 else 0.0


def drop_collinear(path: np.ndarray) -> np.ndarray:
    """Remove interior points that lie on the straight line through their neighbours."""
    if len(path) < 3:
        return path
    d1 = path[1:-1] - path[:-2]
    d2 = path[2:] - path[1:-1]
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    dot = (d1 * d2).sum(axis=1)
    keep = np.concatenate([[True], (np.abs(cross) > 1e-12) | (dot <= 0), [True]])
    return path[keep]


def make_result(path: np.ndarray, start: Pose2D, goal: Pose2D, planner: str, elapsed: float,
                expansions: int = 0, info: dict[str, float] | None = None) -> PlanResult:
    path = np.asarray(path, dtype=float)
    return PlanResult(path=path, length=path_length(path), planning_time_s=elapsed, planner=planner,
                      start=start, goal=goal, expansions=expansions, info=info or {})


def attach_endpoints(costmap: Costmap, cells_xy: np.ndarray, start: Pose2D, goal: Pose2D) -> np.ndarray:
    """Replace the first/last cell centres by the exact start/goal; keep a centre where the direct
    segment to its neighbour would cut through a cell that is not free."""
    pts = [np.array([start.x, start.y])]
    if len(cells_xy) > 1 and not costmap.segment_free((start.x, start.y), tuple(cells_xy[1])):
        pts.append(cells_xy[0])
    pts += list(cells_xy[1:-1])
    if len(cells_xy) > 1 and not costmap.segment_free(tuple(cells_xy[-2]), (goal.x, goal.y)):
        pts.append(cells_xy[-1])
    pts.append(np.array([goal.x, goal.y]))
    return np.asarray(pts, dtype=float)
