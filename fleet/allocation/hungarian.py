"""Optimal assignment (Hungarian method, scipy.optimize.linear_sum_assignment) for one or many tasks per robot.

A round is the exact minimum-cost assignment of at most one task per robot, on the cost of each robot doing
each task next (through a dock when it would run low; infeasible pairs excluded). With no more tasks than
robots, `hungarian` is that one round: the optimum, as brute force over permutations confirms.

With more tasks than robots:

* `hungarian` (routes): link the tasks into routes with the assignment relaxation of routing — give every
  task a predecessor, either a robot's plan end or another task's end, each used at most once, minimising
  total travel (one linear_sum_assignment on a (robots + tasks) × tasks matrix). Chains that start at a
  robot are appended to its plan task by task, each checked with the battery/time-window model (a task that
  fails its check waits for the next pass). Tasks linked into cycles get no robot in that pass; the cheapest
  single entry into them is committed (an auction step) and the next pass chains the rest on from there.
* `hungarian_rounds` (balanced): repeat rounds — every robot gets one more task per round, appended to its
  plan. Each round is optimal given the earlier ones and no robot gets a second task while another has none,
  at the price of much more total travel (docs/benchmarks-allocation.md).

Priorities are lexicographic: a round adds a penalty larger than any cost difference per priority level;
routes are built tier by tier, highest priority first.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from fleet.allocation.model import FleetState, evaluate
from fleet.allocation.types import Plan, Problem, Step


def solve_hungarian(p: Problem) -> Plan:
    st, plan, remaining = _start(p)
    if len(p.tasks) <= len(p.robots):
        _round(p, st, plan, remaining)
    for tier in sorted(set(p.priority[remaining].tolist()), reverse=True):
        while _routes(p, st, plan, remaining, tier):
            pass
    return plan


def solve_hungarian_rounds(p: Problem) -> Plan:
    st, plan, remaining = _start(p)
    while _round(p, st, plan, remaining):
        pass
    return plan


def _start(p: Problem) -> tuple[FleetState, Plan, np.ndarray]:
    return FleetState.initial(p), {r: [] for r in range(len(p.robots))}, np.ones(len(p.tasks), dtype=bool)


def _round(p: Problem, st: FleetState, plan: Plan, remaining: np.ndarray) -> bool:
    """At most one more task per robot, the minimum-cost assignment; False when none could be placed."""
    rows, cols = np.arange(len(p.robots)), np.flatnonzero(remaining)
    if not len(rows) or not len(cols):
        return False
    opt = evaluate(p, st, rows, cols)
    ok = np.isfinite(opt.cost)
    if not ok.any():
        return False
    span = float(opt.cost[ok].max()) + 1.0
    _, rank = np.unique(-p.priority[cols], return_inverse=True)  # 0: highest priority
    tier = len(rows) * span  # more than any difference in a round's total cost
    m = np.where(ok, opt.cost + tier * rank[None, :], tier * (rank.max() + 2))
    ri, ci = linear_sum_assignment(m)
    taken = ok[ri, ci]
    for r, c in zip(ri[taken], ci[taken], strict=True):
        _commit(p, st, plan, int(r), opt.step(int(r), int(c), int(cols[c])), remaining)
    return bool(taken.any())


def _routes(p: Problem, st: FleetState, plan: Plan, remaining: np.ndarray, tier: int) -> bool:
    """One pass of route building over the remaining tasks of one priority; False when none can be placed."""
    cols = np.flatnonzero(remaining & (p.priority == tier))
    n_r = len(p.robots)
    if not len(cols) or not n_r:
        return False
    head = evaluate(p, st, np.arange(n_r), cols)  # robot plan end → task: with charge stops and windows
    link = p.dist[np.ix_(p.end_loc[cols], p.start_loc[cols])].copy()  # task end → task start
    np.fill_diagonal(link, np.inf)
    m = np.vstack([head.cost, link])
    finite = np.isfinite(m)
    if not finite[:n_r].any():
        return False
    ri, ci = linear_sum_assignment(np.where(finite, m, float(m[finite].max() + 1.0) * (len(cols) + 1)))
    pred = np.full(len(cols), -1)
    pred[ci[finite[ri, ci]]] = ri[finite[ri, ci]]
    succ = {int(r): int(c) for c, r in enumerate(pred) if r >= 0}  # predecessor row → task column
    placed = 0
    for r in range(n_r):  # follow each robot's chain, checking every task against the model
        c = succ.get(r)
        while c is not None and remaining[cols[c]]:
            opt = evaluate(p, st, np.array([r]), cols[[c]])
            if not np.isfinite(opt.cost[0, 0]):
                break
            _commit(p, st, plan, r, opt.step(0, 0, int(cols[c])), remaining)
            placed += 1
            c = succ.get(n_r + c)
    if placed:
        return True
    # only cycles (or blocked chains) left: commit the cheapest feasible entry, the next pass chains from it
    opt = evaluate(p, st, np.arange(n_r), cols)
    if not np.isfinite(opt.cost).any():
        return False
    r, c = (int(i) for i in np.unravel_index(int(np.argmin(opt.cost)), opt.cost.shape))
    _commit(p, st, plan, r, opt.step(r, c, int(cols[c])), remaining)
    return True


def _commit(p: Problem, st: FleetState, plan: Plan, r: int, step: Step, remaining: np.ndarray) -> None:
    plan[r].append(step)
    st.commit(p, r, step)
    remaining[step.task] = False
