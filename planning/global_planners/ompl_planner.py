"""Sampling-based global planning with OMPL 2.0 (nanobind bindings) over SE(2).

The validity checker is a plain Python callable doing one lookup in the costmap's free mask (the
inflated costmap, so the robot is a point there). Yaw is free for a round footprint, so the SO(2)
subspace weight is 0 and OMPL's path length is the planar length. Motions are checked every quarter
cell, and the final path is re-checked exactly (every cell each segment touches); a segment that fails
is replaced by a Theta* sub-path on the same grid.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from planning.global_planners.common import check_endpoint, check_reachable, drop_collinear, make_result
from planning.global_planners.grid_astar import GridPlanner
from planning.types import Costmap, PlanResult
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

ALGORITHMS: dict[str, Callable[[ob.SpaceInformation], ob.Planner]] = {
    "rrt_connect": og.RRTConnect,
    "rrt_star": og.RRTstar,
    "informed_rrt_star": og.InformedRRTstar,
    "bit_star": og.BITstar,
    "prm_star": og.PRMstar,
}
ANYTIME = frozenset({"rrt_star", "informed_rrt_star", "bit_star", "prm_star"})  # use the whole budget

ou.setLogLevel(ou.LogLevel.LOG_NONE)  # OMPL logs every solve at INFO; our errors say what matters


class OmplPlanner:
    """One OMPL geometric planner by name, with a wall-clock budget and path simplification."""

    def __init__(self, *, algorithm: str = "rrt_connect", time_budget_s: float = 0.25,
                 simplify: bool = True, seed: int | None = None, name: str | None = None) -> None:
        if algorithm not in ALGORITHMS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown OMPL algorithm '{algorithm}'",
                             f"known algorithms: {', '.join(sorted(ALGORITHMS))}")
        if not (math.isfinite(time_budget_s) and time_budget_s > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"time_budget_s must be > 0, got {time_budget_s}",
                             "e.g. 0.25")
        self.algorithm = algorithm
        self.time_budget_s = time_budget_s
        self.simplify = simplify
        self.seed = seed
        self.name = name or algorithm

    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap) -> PlanResult:
        t0 = time.perf_counter()
        s_rc = check_endpoint(costmap, start, "start")
        g_rc = check_endpoint(costmap, goal, "goal")
        check_reachable(costmap, s_rc, g_rc)
        if self.seed is not None:
            ou.RNG.setSeed(self.seed)
        si, space = _space_information(costmap)
        pdef = ob.ProblemDefinition(si)
        pdef.setStartAndGoalStates(_state(space, start), _state(space, goal))
        pdef.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
        planner = ALGORITHMS[self.algorithm](si)
        planner.setProblemDefinition(pdef)
        planner.setup()
        status = planner.solve(self.time_budget_s)
        if not pdef.hasExactSolution():
            raise FleetError(ErrorCode.PLANNING_FAILED,
                             f"no path found by {self.algorithm} within {self.time_budget_s:.3g} s ({status})",
                             "raise time_budget_s, or use the deterministic 'theta_star' planner")
        path = pdef.getSolutionPath()
        raw_length = _planar_length(path)
        if self.simplify:
            og.PathSimplifier(si).simplifyMax(path)
        xy = np.array([[path.getState(i).getX(), path.getState(i).getY()] for i in range(path.getStateCount())])
        xy = _repair(xy, start, goal, costmap)
        # No vertex count: BIT*'s PlannerData keeps the space alive until exit (a nanobind leak report).
        return make_result(drop_collinear(xy), start, goal, self.name, time.perf_counter() - t0,
                           info={"raw_length": raw_length})


def _space_information(costmap: Costmap) -> tuple[ob.SpaceInformation, ob.SE2StateSpace]:
    xmin, ymin, xmax, ymax = costmap.bounds
    space = ob.SE2StateSpace()
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0, xmin)
    bounds.setLow(1, ymin)
    bounds.setHigh(0, xmax)
    bounds.setHigh(1, ymax)
    space.setBounds(bounds)
    space.setSubspaceWeight(1, 0.0)  # yaw does not matter for a round robot: planar distance only
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(_validity_checker(costmap))
    si.setStateValidityCheckingResolution(0.25 * costmap.resolution / space.getMaximumExtent())
    si.setup()
    return si, space


def _validity_checker(costmap: Costmap) -> Callable[[ob.State], bool]:
    """One free-mask lookup per state; the mask is flattened to bytes so the check stays in Python ints."""
    free_mask = costmap.free_mask
    h, w = free_mask.shape
    free = np.ascontiguousarray(free_mask, dtype=np.uint8).tobytes()
    xmin, ymin, _, _ = costmap.bounds
    inv = 1.0 / costmap.resolution

    def valid(state: ob.State) -> bool:
        c = math.floor((state.getX() - xmin) * inv)
        r = math.floor((state.getY() - ymin) * inv)
        return 0 <= r < h and 0 <= c < w and free[r * w + c] == 1

    return valid


def _state(space: ob.SE2StateSpace, pose: Pose2D) -> ob.State:
    s = space.allocState()
    s.setX(pose.x)
    s.setY(pose.y)
    s.setYaw(pose.yaw)
    return s


def _planar_length(path: og.PathGeometric) -> float:
    pts = np.array([[path.getState(i).getX(), path.getState(i).getY()] for i in range(path.getStateCount())])
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def _repair(xy: np.ndarray, start: Pose2D, goal: Pose2D, costmap: Costmap) -> np.ndarray:
    """Exact check of every segment; a segment that clips a blocked cell becomes a Theta* sub-path."""
    xy[0], xy[-1] = (start.x, start.y), (goal.x, goal.y)
    out = [xy[0]]
    theta = GridPlanner(any_angle=True)
    for a, b in itertools.pairwise(xy):
        if costmap.segment_free(tuple(a), tuple(b)):
            out.append(b)
            continue
        sub = theta.plan(Pose2D(float(a[0]), float(a[1])), Pose2D(float(b[0]), float(b[1])), costmap)
        out.extend(sub.path[1:])
    return np.asarray(out, dtype=float)
