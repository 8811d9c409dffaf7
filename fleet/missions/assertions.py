"""Assertions (`assertions:` in a mission file), each chosen by `type:`, evaluated on what the run measured.

Every assertion reports the measured figure next to the requirement, so a failure message carries numbers
(it becomes the JUnit failure text). Robots and task keys are checked against the mission at load time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

from pydantic import Field, model_validator

from fleet.missions import measures
from fleet.missions.registry import Registry
from fleet.missions.types import AssertionResult, PoseSpec, RunData
from sim.config import StrictModel

AssertFn = Callable[..., AssertionResult]
ASSERTIONS: Registry[AssertFn] = Registry("assertion type")


class AssertionBase(StrictModel):
    type: str
    name: str | None = Field(None, description="label in reports (default: type and index)")


class ReachGoal(AssertionBase):
    type: Literal["reach_goal"] = "reach_goal"
    robot: str
    goal: PoseSpec | None = Field(None, description="default: the goal of `task`")
    task: str | None = Field(None, description="a go_to task key whose goal is meant")
    tolerance: float = Field(0.3, gt=0, description="m")
    within: float | None = Field(None, gt=0, description="sim s (default: the time limit)")

    @model_validator(mode="after")
    def _goal_or_task(self) -> ReachGoal:
        if (self.goal is None) == (self.task is None):
            raise ValueError("give exactly one of goal or task")
        return self


class NoCollisions(AssertionBase):
    type: Literal["no_collisions"] = "no_collisions"
    robots: list[str] | None = Field(None, description="default: every robot")


class MinClearance(AssertionBase):
    type: Literal["min_clearance"] = "min_clearance"
    distance: float = Field(ge=0, description="smallest allowed gap from a footprint, m")
    against: Literal["static", "robots", "both"] = "both"
    robots: list[str] | None = None


class Coverage(AssertionBase):
    type: Literal["coverage"] = "coverage"
    min_pct: float = Field(ge=0, le=100)
    task: str | None = Field(None, description="a cover_area task key: its polygon, holes and tool width")
    polygon: list[tuple[float, float]] | None = Field(None, min_length=3)
    holes: list[list[tuple[float, float]]] = Field(default_factory=list)
    tool_width: float | None = Field(None, gt=0)
    robots: list[str] | None = Field(None, description="whose trajectories sweep (default: the task's robot, or all)")

    @model_validator(mode="after")
    def _region(self) -> Coverage:
        if (self.polygon is None) == (self.task is None):
            raise ValueError("give exactly one of task or polygon")
        if self.polygon is not None and self.tool_width is None:
            raise ValueError("a polygon needs tool_width")
        return self


class AllTasksDone(AssertionBase):
    type: Literal["all_tasks_done"] = "all_tasks_done"
    by: float | None = Field(None, gt=0, description="sim s (default: the time limit)")
    tasks: list[str] | None = Field(None, description="task keys (default: every task of the mission)")


class SlamAte(AssertionBase):
    type: Literal["slam_ate"] = "slam_ate"
    robot: str
    max_m: float = Field(gt=0, description="largest allowed ATE RMSE, m")


class BarnScore(AssertionBase):
    type: Literal["barn_score"] = "barn_score"
    robot: str
    task: str = Field(description="a go_to task key")
    min: float = Field(gt=0, le=0.5, description="success × T_opt / clip(T, 2·T_opt, 8·T_opt) is at most 0.5")


class TaskStateIs(AssertionBase):
    type: Literal["task_state"] = "task_state"
    task: str
    state: list[Literal["succeeded", "failed", "canceled", "active", "queued"]] = Field(min_length=1)


class EventCount(AssertionBase):
    type: Literal["event_count"] = "event_count"
    kind: str = Field(description="an event kind: collision, near_miss, estop, task_failed, ...")
    min: int = Field(0, ge=0)
    max: int | None = Field(None, ge=0)


class BehaviourMetric(AssertionBase):
    type: Literal["behaviour_metric"] = "behaviour_metric"
    behaviour: str = Field(description="a behaviour key")
    metric: str = Field(description="e.g. alignment, cohesion_radius, min_gap (see behaviour_status)")
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _bound(self) -> BehaviourMetric:
        if self.min is None and self.max is None:
            raise ValueError("give min, max or both")
        return self


def _result(a: AssertionBase, name: str, passed: bool, measured: float | str | None, expected: str,
            message: str, **details: object) -> AssertionResult:
    return AssertionResult(name, a.type, bool(passed), measured, expected, message,
                           dict(details))


@ASSERTIONS.register("reach_goal", ReachGoal)
def reach_goal(a: ReachGoal, data: RunData, name: str) -> AssertionResult:
    goal = a.goal.pose() if a.goal is not None else measures.task_goal(data, a.task or "")
    within = a.within or data.time_limit
    first, closest = measures.first_within(data.traj.get(a.robot), goal.x, goal.y, a.tolerance)
    ok = first is not None and first <= within
    got = f"reached at t={first:.2f} s" if first is not None else f"closest {closest:.3f} m"
    return _result(a, name, ok, first if first is not None else closest, f"within {a.tolerance} m by {within:g} s",
                   f"{a.robot} → ({goal.x:.2f}, {goal.y:.2f}): {got}; required within {a.tolerance} m by "
                   f"t={within:g} s", closest_m=closest, goal=goal)


@ASSERTIONS.register("no_collisions", NoCollisions)
def no_collisions(a: NoCollisions, data: RunData, name: str) -> AssertionResult:
    hits = [c for c in data.collisions if a.robots is None or c["robot"] in a.robots]
    first = f"; first: {hits[0]['robot']} hit {', '.join(hits[0]['others']) or 'something'} at " \
            f"t={hits[0]['t']:.2f} s" if hits else ""
    return _result(a, name, not hits, float(len(hits)), "0 collisions", f"{len(hits)} collisions{first}",
                   collisions=hits[:20])


@ASSERTIONS.register("min_clearance", MinClearance)
def min_clearance(a: MinClearance, data: RunData, name: str) -> AssertionResult:
    static = min((d for r, d in data.min_static_clearance.items() if a.robots is None or r in a.robots),
                 default=math.inf)
    gap = data.min_robot_gap
    got = {"static": static, "robots": gap, "both": min(static, gap)}[a.against]
    return _result(a, name, got >= a.distance, got, f"≥ {a.distance} m",
                   f"min clearance ({a.against}) {got:.3f} m; required ≥ {a.distance} m",
                   static_m=static, robots_m=gap)


@ASSERTIONS.register("coverage", Coverage)
def coverage(a: Coverage, data: RunData, name: str) -> AssertionResult:
    if a.task is not None:
        rec = data.tasks[a.task]
        poly, holes = rec.params["polygon"], rec.params.get("holes") or []
        tool = float(rec.params.get("tool_width", 0.5))
        robots = a.robots or [rec.robot]
    else:
        poly, holes, tool = a.polygon or [], a.holes, float(a.tool_width or 0.0)
        robots = a.robots or list(data.traj)
    pct = measures.swept_coverage([data.traj[r] for r in robots if r in data.traj], poly, holes, tool)
    return _result(a, name, pct >= a.min_pct, pct, f"≥ {a.min_pct}%",
                   f"covered {pct:.1f}% (tool {tool} m, swept by {', '.join(robots)}); required ≥ {a.min_pct}%")


@ASSERTIONS.register("all_tasks_done", AllTasksDone)
def all_tasks_done(a: AllTasksDone, data: RunData, name: str) -> AssertionResult:
    by = a.by or data.time_limit
    keys = a.tasks or list(data.tasks)
    late = [k for k in keys if not (data.tasks[k].state == "succeeded" and (data.tasks[k].finished or 0.0) <= by)]
    done = len(keys) - len(late)
    why = "; ".join(f"{k}: {data.tasks[k].state}" + (f" at t={data.tasks[k].finished:.1f} s"
                                                       if data.tasks[k].finished is not None else "")
                    + (f" ({data.tasks[k].reason})" if data.tasks[k].reason else "") for k in late[:5])
    last = max((data.tasks[k].finished or 0.0 for k in keys if k not in late), default=0.0)
    return _result(a, name, not late and bool(keys), float(done), f"{len(keys)} of {len(keys)} succeeded by {by:g} s",
                   f"{done}/{len(keys)} tasks succeeded by t={by:g} s (last at t={last:.1f} s)"
                   + (f"; not done: {why}" if late else ""), not_done=late)


@ASSERTIONS.register("slam_ate", SlamAte)
def slam_ate(a: SlamAte, data: RunData, name: str) -> AssertionResult:
    s = data.slam.get(a.robot)
    if not s or not math.isfinite(s.get("ate_rmse", math.nan)):
        return _result(a, name, False, None, f"ATE ≤ {a.max_m} m", f"no SLAM estimate for {a.robot}")
    ate = s["ate_rmse"]
    return _result(a, name, ate <= a.max_m, ate, f"ATE ≤ {a.max_m} m",
                   f"{a.robot} SLAM ATE RMSE {ate:.3f} m over {int(s['poses'])} poses; required ≤ {a.max_m} m")


@ASSERTIONS.register("barn_score", BarnScore)
def barn_score(a: BarnScore, data: RunData, name: str) -> AssertionResult:
    score, t, t_opt = measures.barn(data, a.robot, a.task)
    return _result(a, name, score >= a.min, score, f"≥ {a.min}",
                   f"BARN score {score:.3f} (T={t:.2f} s, T_opt={t_opt:.2f} s); required ≥ {a.min}",
                   t_s=t, t_opt_s=t_opt)


@ASSERTIONS.register("task_state", TaskStateIs)
def task_state(a: TaskStateIs, data: RunData, name: str) -> AssertionResult:
    rec = data.tasks[a.task]
    return _result(a, name, rec.state in a.state, rec.state, " or ".join(a.state),
                   f"task {a.task} is {rec.state}" + (f" ({rec.reason})" if rec.reason else "")
                   + f"; required {' or '.join(a.state)}")


@ASSERTIONS.register("event_count", EventCount)
def event_count(a: EventCount, data: RunData, name: str) -> AssertionResult:
    n = data.event_counts.get(a.kind, 0)
    ok = n >= a.min and (a.max is None or n <= a.max)
    req = f"{a.min} ≤ n" + (f" ≤ {a.max}" if a.max is not None else "")
    return _result(a, name, ok, float(n), req, f"{n} '{a.kind}' events; required {req}")


@ASSERTIONS.register("behaviour_metric", BehaviourMetric)
def behaviour_metric(a: BehaviourMetric, data: RunData, name: str) -> AssertionResult:
    metrics = data.behaviours.get(a.behaviour, {}).get("metrics", {})
    v = metrics.get(a.metric)
    req = " and ".join(s for s in (f"≥ {a.min}" if a.min is not None else "",
                                   f"≤ {a.max}" if a.max is not None else "") if s)
    if v is None:
        return _result(a, name, False, None, req, f"behaviour {a.behaviour} has no metric '{a.metric}' "
                       f"(metrics: {', '.join(sorted(metrics)) or 'none'})")
    ok = (a.min is None or v >= a.min) and (a.max is None or v <= a.max)
    return _result(a, name, ok, float(v), req, f"{a.behaviour}.{a.metric} = {v:.3f}; required {req}")
