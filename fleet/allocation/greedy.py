"""The baseline: tasks in order (priority first, then as given), each to the robot that can append it most
cheaply (the nearest robot, counting from the end of its plan so far). What a dispatcher does without an
optimiser; the benchmarks measure the others against it."""

from __future__ import annotations

import numpy as np

from fleet.allocation.model import FleetState, evaluate
from fleet.allocation.types import Plan, Problem


def solve_greedy(p: Problem) -> Plan:
    st = FleetState.initial(p)
    plan: Plan = {r: [] for r in range(len(p.robots))}
    rows = np.arange(len(p.robots))
    for t in sorted(range(len(p.tasks)), key=lambda t: (-p.priority[t], t)):
        if not len(rows):
            break
        opt = evaluate(p, st, rows, np.array([t]))
        r = int(np.argmin(opt.cost[:, 0]))
        if not np.isfinite(opt.cost[r, 0]):
            continue  # nobody can: reported as infeasible
        step = opt.step(r, 0, t)
        plan[r].append(step)
        st.commit(p, r, step)
    return plan
