"""A lower bound on the approach travel of any allocation: the assignment relaxation of multi-robot routing.

Every allocation gives each task one predecessor — the robot that starts there, or the task done just before
it — and each robot or task precedes at most one task. Dropping the rule that these links form chains from
robots (no cycles) leaves an assignment problem, solved exactly by linear_sum_assignment on the (robots +
tasks) × tasks matrix of travel from each predecessor's end to each task's start. Its optimum is therefore
never above the best allocation's travel (batteries and time windows only restrict the allocations further,
and a charge stop never shortens a leg when distances obey the triangle inequality).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from fleet.allocation.types import Problem


def travel_lower_bound(p: Problem, tasks: np.ndarray) -> float:
    """Lower bound on the travel of any allocation that does exactly `tasks` (indices into p.tasks)."""
    tasks = np.asarray(tasks, dtype=int)
    n_r, n_t = len(p.robots), len(tasks)
    if not n_t or not n_r:
        return 0.0
    rows = np.concatenate([p.robot_loc, p.end_loc[tasks]])
    m = p.dist[np.ix_(rows, p.start_loc[tasks])].copy()
    m[n_r + np.arange(n_t), np.arange(n_t)] = np.inf  # a task does not precede itself
    finite = np.isfinite(m)
    big = float(m[finite].max() + 1.0) * (n_t + 1) if finite.any() else 1.0
    ri, ci = linear_sum_assignment(np.where(finite, m, big))
    ok = finite[ri, ci]
    return float(m[ri[ok], ci[ok]].sum())
