"""Market mode: a sequential single-item auction (SSI). Every round each robot bids on every open task its
marginal cost — the extra travel of appending the task to its plan so far (through a dock if it would
run low) — and the lowest bid over all robots and tasks wins. Only the winner's bids change, so a round
costs one vectorised re-evaluation of one robot. Open tasks are auctioned in priority tiers: no
lower-priority task is sold while a higher one can still be.
"""

from __future__ import annotations

import numpy as np

from fleet.allocation.model import FleetState, evaluate
from fleet.allocation.types import Plan, Problem


def solve_auction(p: Problem) -> Plan:
    st = FleetState.initial(p)
    plan: Plan = {r: [] for r in range(len(p.robots))}
    n_r, n_t = len(p.robots), len(p.tasks)
    if not n_r or not n_t:
        return plan
    cols = np.arange(n_t)
    opt = evaluate(p, st, np.arange(n_r), cols)
    bids = opt.cost.copy()
    sold = np.zeros(n_t, dtype=bool)
    while True:
        bids[:, sold] = np.inf
        open_ = np.isfinite(bids).any(axis=0)
        if not open_.any():
            break
        top = p.priority[open_].max()
        masked = np.where((p.priority == top)[None, :], bids, np.inf)
        r, t = (int(i) for i in np.unravel_index(int(np.argmin(masked)), masked.shape))
        step = opt.step(r, t, t)
        plan[r].append(step)
        st.commit(p, r, step)
        sold[t] = True
        row = evaluate(p, st, np.array([r]), cols)  # only the winner's bids change: from its plan's new end
        for name in ("cost", "begin", "finish", "soc_after", "dock", "charge_s", "code"):
            getattr(opt, name)[r] = getattr(row, name)[0]
        bids[r] = row.cost[0]
    return plan
