"""The BARN score and its breakdown, from a run's trajectory and the world's ground truth.

BARN (Perille et al., "Benchmarking Metric Ground Navigation", 2020; the BARN challenge at ICRA) scores one
run as `success × T_opt / clip(T, 2·T_opt, 8·T_opt)`, with T_opt = optimal path length / max speed: a
success scores between 0.125 (slower than 8·T_opt) and 0.5 (2·T_opt or faster), a failure scores 0.
The optimal length is an any-angle grid path for the robot's inscribed disc (costmap with no extra padding).
Clearance is exact: python-fcl distance from the robot's footprint polygon to the static obstacles.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from fleet.grading.types import RunResult, RunScore, Stat
from planning import FclWorld, LayeredCostmap, PlanResult, get_planner
from planning.collision import Footprint
from sim.types import Pose2D, WorldDescription

MOVING = 0.05  # m/s: below this the robot counts as stopped (curvature is undefined)


def barn_score(success: bool, t: float, t_opt: float) -> float:
    """success × T_opt / clip(T, 2·T_opt, 8·T_opt), exactly."""
    if not success:
        return 0.0
    return t_opt / min(max(t, 2.0 * t_opt), 8.0 * t_opt)


def optimal_path(desc: WorldDescription, start: Pose2D, goal: Pose2D, *, robot_radius: float,
                 planner: str = "guided_theta_star", resolution: float = 0.05) -> PlanResult:
    """The shortest path a disc of `robot_radius` can take (raises PLANNING_FAILED if there is none). The map
    spans the world's obstacles and both endpoints, with room to go around."""
    x0, y0, x1, y1 = desc.bounds(margin=0.5)
    room = robot_radius + 1.0
    bounds = (min(x0, start.x - room, goal.x - room), min(y0, start.y - room, goal.y - room),
              max(x1, start.x + room, goal.x + room), max(y1, start.y + room, goal.y + room))
    costmap = LayeredCostmap.from_world(desc, robot_radius=robot_radius, resolution=resolution, padding=0.0,
                                        bounds=bounds)
    return get_planner(planner).plan(start, goal, costmap)


def clearances(traj: np.ndarray, fcl_world: FclWorld, footprint: Footprint) -> np.ndarray:
    """Footprint-to-obstacle distance at every trajectory row (0 when touching)."""
    return np.array([fcl_world.min_distance(Pose2D(float(x), float(y), float(yaw)), footprint)
                     for x, y, yaw in traj[:, 1:4]])


def score_run(traj: np.ndarray, *, success: bool, t: float, optimal_length: float, v_max: float,
              collision_times: Sequence[float], clearance: np.ndarray, safety_distance: float,
              goal: Pose2D, success_radius: float = 0.0) -> RunScore:
    """The breakdown of one run. `traj` rows are (t, x, y, yaw, v, w) at the control rate, `clearance` one
    value per row; `t` is the time to the goal (or the run's duration when it was not reached).

    SPL (Anderson et al. 2018) divides by the shortest distance to the success disc, optimal length − radius
    (exact when the optimal path's last segment is at least the radius long), so a run that stops at the
    disc's edge along the optimal path scores 1, not more than 1 clipped."""
    t_opt = optimal_length / v_max
    to_disc = max(optimal_length - success_radius, 0.0)
    if len(traj) == 0:
        traj = np.zeros((0, 6))
    xy = traj[:, 1:3]
    length = float(np.hypot(*np.diff(xy, axis=0).T).sum()) if len(traj) > 1 else 0.0
    dt = np.diff(traj[:, 0])
    # Each sample holds until the next one (rectangle rule); the last one has no duration.
    hold = np.append(dt, 0.0) if len(traj) else np.zeros(0)
    v, w = traj[:, 4], traj[:, 5]
    accel, jerk = _derivatives(traj[:, 0], v)
    _, ang_jerk = _derivatives(traj[:, 0], w)
    travelled = float(np.sum(np.abs(v) * hold))
    moving = np.abs(v) > MOVING
    final = math.hypot(goal.x - xy[-1, 0], goal.y - xy[-1, 1]) if len(traj) else math.nan
    return RunScore(
        success=success, score=barn_score(success, t, t_opt), time=t, t_opt=t_opt,
        optimal_length=optimal_length, path_length=length,
        spl=(to_disc / max(length, to_disc) if to_disc > 0 else 1.0) if success else 0.0,
        collisions=len(collision_times), first_collision_time=min(collision_times) if collision_times else None,
        min_clearance=float(clearance.min()) if clearance.size else math.nan,
        time_in_danger=float(np.sum(hold[clearance < safety_distance])),
        mean_speed=length / float(traj[-1, 0] - traj[0, 0]) if len(traj) > 1 and traj[-1, 0] > traj[0, 0] else 0.0,
        accel_rms=_rms(accel), jerk_rms=_rms(jerk), angular_jerk_rms=_rms(ang_jerk),
        curvature_mean=float(np.sum(np.abs(w) * hold)) / travelled if travelled > 0 else 0.0,
        curvature_max=float(np.max(np.abs(w[moving] / v[moving]))) if moving.any() else 0.0,
        final_distance=final)


def _derivatives(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and second finite differences of x(t)."""
    if len(t) < 2:
        return np.zeros(0), np.zeros(0)
    d1 = np.diff(x) / np.diff(t)
    tm = 0.5 * (t[1:] + t[:-1])
    d2 = np.diff(d1) / np.diff(tm) if len(d1) > 1 else np.zeros(0)
    return d1, d2


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if x.size else 0.0


SUMMARY_FIELDS = ("score", "time", "path_length", "spl", "min_clearance", "time_in_danger", "mean_speed",
                  "accel_rms", "jerk_rms", "curvature_mean", "collisions")


def summarize(runs: Sequence[RunResult]) -> dict[str, Any]:
    """Over runs: success rate, then mean / spread / range per figure. Score and SPL count every run (0 on a
    failure, as their definitions say); time and path length are over the successful runs only."""
    ok = [r for r in runs if r.score.success]
    out: dict[str, Any] = {"runs": len(runs), "successes": len(ok),
                           "success_rate": len(ok) / len(runs) if runs else 0.0,
                           "outcomes": {o: sum(r.outcome == o for r in runs) for o in {r.outcome.value for r in runs}}}
    for name in SUMMARY_FIELDS:
        pool = ok if name in ("time", "path_length") else runs
        out[name] = Stat.of([float(getattr(r.score, name)) for r in pool]).to_dict()
    out["t_opt"] = runs[0].score.t_opt if runs else math.nan
    return out
