"""allocate(): requests + robots → Problem (travel table, arrays) → a solver → an Allocation with paths,
ETAs, costs and the reasons for every task that could not be placed. Pure: nothing here touches the world."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from fleet.allocation.auction import solve_auction
from fleet.allocation.bound import travel_lower_bound
from fleet.allocation.greedy import solve_greedy
from fleet.allocation.hungarian import solve_hungarian, solve_hungarian_rounds
from fleet.allocation.model import DEADLINE, ENERGY, OK, UNREACHABLE, FleetState, evaluate
from fleet.allocation.travel import Travel, TravelTable
from fleet.allocation.types import (
    Allocation,
    Assignment,
    Energy,
    Infeasible,
    Plan,
    Problem,
    TaskRequest,
)
from sim.errors import ErrorCode, unknown_name

SOLVERS: dict[str, Callable[[Problem], Plan]] = {
    "hungarian": solve_hungarian, "hungarian_rounds": solve_hungarian_rounds, "auction": solve_auction,
    "greedy": solve_greedy}


@dataclass(frozen=True, slots=True)
class RobotInput:
    name: str
    x: float
    y: float
    soc: float
    speed: float  # m/s the ETAs assume


def build_problem(now: float, robots: list[RobotInput], requests: list[TaskRequest],
                  docks: Mapping[str, tuple[float, float]], travel: Travel,
                  energy: Energy) -> tuple[Problem, TravelTable]:
    n_r, n_t, n_k = len(robots), len(requests), len(docks)
    pts = np.array([[r.x, r.y] for r in robots] + [list(q.profile.start) for q in requests]
                   + [list(q.profile.end) for q in requests] + [list(xy) for xy in docks.values()],
                   dtype=float).reshape(-1, 2)
    starts = n_r + np.arange(n_t)
    dock_loc = n_r + 2 * n_t + np.arange(n_k)
    table = travel.table(pts, np.concatenate([starts, dock_loc]))  # every pair used has a start or a dock
    prob = Problem(
        now=now, robots=[r.name for r in robots], robot_loc=np.arange(n_r), soc=np.array([r.soc for r in robots]),
        speed=np.array([r.speed for r in robots]), tasks=requests, start_loc=starts, end_loc=starts + n_t,
        work_len=np.array([q.profile.length for q in requests]),
        work_time=np.array([q.profile.duration for q in requests]),
        priority=np.array([q.priority for q in requests], dtype=int),
        earliest=np.array([q.earliest_start for q in requests]), deadline=np.array([q.deadline for q in requests]),
        docks=list(docks), dock_loc=dock_loc, dist=table.dist, energy=energy)
    return prob, table


def allocate(method: str, now: float, robots: list[RobotInput], requests: list[TaskRequest],
             docks: Mapping[str, tuple[float, float]], travel: Travel, energy: Energy) -> Allocation:
    if method not in SOLVERS:
        raise unknown_name("allocation method", method, list(SOLVERS), ErrorCode.INVALID_ARGUMENT)
    t0 = time.perf_counter()
    prob, table = build_problem(now, robots, requests, docks, travel, energy)
    t1 = time.perf_counter()
    plan = SOLVERS[method](prob)
    t2 = time.perf_counter()
    assignments = [_assignment(prob, table, r, k, plan) for r in plan for k in range(len(plan[r]))]
    placed = {s.task for steps in plan.values() for s in steps}
    infeasible = [Infeasible(q.id, q.type, why_infeasible(prob, i)) for i, q in enumerate(requests) if i not in placed]
    finish = [a.finish for a in assignments]
    return Allocation(method=method, cost_model=travel.name, now=now, dry_run=True, assignments=assignments,
                      infeasible=infeasible, travel_m=float(sum(a.travel_m for a in assignments)),
                      work_m=float(sum(a.work_m for a in assignments)),
                      makespan_s=max(finish) - now if finish else 0.0, solve_time_s=t2 - t1, table_time_s=t1 - t0,
                      travel_lower_bound_m=travel_lower_bound(prob, np.array(sorted(placed), dtype=int)))


def _assignment(p: Problem, table: TravelTable, r: int, k: int, plan: Plan) -> Assignment:
    step = plan[r][k]
    q = p.tasks[step.task]
    here = p.robot_loc[r] if k == 0 else p.end_loc[plan[r][k - 1].task]
    start = p.start_loc[step.task]
    if step.dock >= 0:
        via = p.dock_loc[step.dock]
        legs = [table.path(int(here), int(via)), table.path(int(via), int(start))]
    else:
        legs = [table.path(int(here), int(start))]
    if q.profile.path is not None and len(q.profile.path) > 1:
        legs.append(np.asarray(q.profile.path, dtype=float))
    path = np.vstack([legs[0]] + [leg[1:] for leg in legs[1:]])
    return Assignment(request=q.id, type=q.type, robot=p.robots[r], order=k, priority=q.priority,
                      charge_dock=p.docks[step.dock] if step.dock >= 0 else None, travel_m=step.travel,
                      work_m=float(p.work_len[step.task]), begin=step.begin, finish=step.finish,
                      soc_after=step.soc_after, charge_s=step.charge_s, path=path)


def why_infeasible(p: Problem, t: int) -> str:
    """Why task t got no robot: judged against the robots as they are now, then against their plans."""
    e, dl = p.earliest[t], p.deadline[t]
    if e > dl:
        return f"empty time window: earliest_start {e:.1f} s is after the deadline {dl:.1f} s"
    if not p.robots:
        return "no robot available"
    opt = evaluate(p, FleetState.initial(p), np.arange(len(p.robots)), np.array([t]))
    code = opt.code[:, 0]
    if (code == UNREACHABLE).all():
        x, y = p.tasks[t].profile.start
        row = np.delete(p.dist[p.start_loc[t]], p.start_loc[t])
        if not np.isfinite(row).any():
            return f"unreachable: its start ({x:.2f}, {y:.2f}) is inside an obstacle or outside the map"
        return f"unreachable: no path from any robot to its start ({x:.2f}, {y:.2f})"
    if np.isin(code, (UNREACHABLE, ENERGY)).all():
        docks = "" if p.docks else "; the world has no docks to charge at"
        return (f"battery: no robot can do it and keep the {p.energy.reserve:.0%} reserve, even after "
                f"charging{docks}")
    if not (code == OK).any():
        best = float(np.min(np.where(code == DEADLINE, opt.finish[:, 0], np.inf)))
        return f"deadline {dl:.1f} s: the earliest any robot could finish is {best:.1f} s"
    return f"deadline {dl:.1f} s: the robots that could make it are busy with other tasks until too late"

