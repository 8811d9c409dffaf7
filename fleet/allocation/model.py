"""The cost model every solver shares: what it costs robot r to do task t next, and whether it can.

A robot's plan state is where it is, when it is free and its charge. Appending task t:

  direct:   start at max(free, earliest_start) (the task manager holds it until then: `not_before`), drive
            to t's start, do the work; the charge left is soc − (drive_wh_per_m · m + idle_w · s) / capacity.
  via dock: when the direct charge left would fall below the reserve (Open-RMF's rule), first drive to a dock,
            charge to `charge_to` (at charge_w − idle_w net), then go on; the dock with the shortest detour.

The option is feasible when the start is reachable, the charge stays ≥ reserve, and it ends by the deadline.
Its cost is the approach travel in metres (the work itself costs the same whoever does it). Everything is
vectorised over (robots × tasks × docks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fleet.allocation.types import Problem, Step

OK, UNREACHABLE, ENERGY, DEADLINE = 0, 1, 2, 3


@dataclass
class FleetState:
    """Each robot's plan so far: last location, when it is free, its charge then."""

    loc: np.ndarray
    time: np.ndarray
    soc: np.ndarray

    @classmethod
    def initial(cls, p: Problem) -> FleetState:
        return cls(p.robot_loc.copy(), np.full(len(p.robots), p.now), p.soc.copy())

    def commit(self, p: Problem, r: int, step: Step) -> None:
        self.loc[r], self.time[r], self.soc[r] = p.end_loc[step.task], step.finish, step.soc_after


@dataclass
class Options:
    """(rows × cols) arrays for the chosen option (direct or via a dock) of each robot/task pair."""

    cost: np.ndarray  # m of approach travel (inf where infeasible)
    begin: np.ndarray
    finish: np.ndarray
    soc_after: np.ndarray
    dock: np.ndarray  # dock index or -1
    charge_s: np.ndarray
    code: np.ndarray  # OK | UNREACHABLE | ENERGY | DEADLINE

    def step(self, i: int, j: int, task: int) -> Step:
        return Step(task=task, dock=int(self.dock[i, j]), travel=float(self.cost[i, j]),
                    begin=float(self.begin[i, j]), finish=float(self.finish[i, j]),
                    soc_after=float(self.soc_after[i, j]), charge_s=float(self.charge_s[i, j]))


def evaluate(p: Problem, st: FleetState, rows: np.ndarray, cols: np.ndarray) -> Options:
    e = p.energy
    v = p.speed[rows][:, None]
    t0, s0, loc = st.time[rows][:, None], st.soc[rows][:, None], st.loc[rows]
    start = p.start_loc[cols]
    early, dl = p.earliest[cols][None, :], p.deadline[cols][None, :]
    wl, wt = p.work_len[cols][None, :], p.work_time[cols][None, :]

    def used(metres: np.ndarray, seconds: np.ndarray) -> np.ndarray:  # state of charge spent
        return (e.drive_wh_per_m * metres + e.idle_w * seconds / 3600.0) / e.capacity_wh

    with np.errstate(invalid="ignore"):
        # direct
        d1 = p.dist[np.ix_(loc, start)]
        begin = np.maximum(t0, early)
        finish = begin + (d1 + wl) / v + wt
        soc = s0 - used(d1 + wl, finish - t0)
        reach = np.isfinite(d1)
        energy_ok = reach & (soc >= e.reserve)
        # via each dock k: (rows, K, cols)
        dock, charge_s = np.full(d1.shape, -1), np.zeros(d1.shape)
        cost = np.where(reach, d1, np.inf)
        net_w = e.charge_w - e.idle_w
        if len(p.dock_loc) and net_w > 0:
            a = p.dist[np.ix_(loc, p.dock_loc)][:, :, None]  # robot → dock
            b = p.dist[np.ix_(p.dock_loc, start)][None, :, :]  # dock → task start
            t_dock = t0[:, :, None] + a / v[:, :, None]
            soc_dock = s0[:, :, None] - used(a, a / v[:, :, None])
            soc_ready = np.maximum(soc_dock, e.charge_to)
            t_charge = np.maximum(0.0, e.charge_to - soc_dock) * e.capacity_wh / net_w * 3600.0
            t_ready = t_dock + t_charge
            vb = np.maximum(t_ready, early[:, None, :])
            fin_b = vb + (b + wl[:, None, :]) / v[:, :, None] + wt[:, None, :]
            soc_b = soc_ready - used(b + wl[:, None, :], fin_b - t_ready)
            ok_b = np.isfinite(a + b) & (soc_dock >= 0) & (soc_b >= e.reserve)
            cost_b = np.where(ok_b, a + b, np.inf)
            k = np.argmin(cost_b, axis=1)  # the dock with the shortest detour

            def pick(arr: np.ndarray) -> np.ndarray:
                return np.take_along_axis(np.broadcast_to(arr, cost_b.shape), k[:, None, :], 1)[:, 0]

            use_b = ~energy_ok & np.isfinite(pick(cost_b))
            cost = np.where(energy_ok, d1, np.where(use_b, pick(cost_b), np.inf))
            begin = np.where(use_b, pick(vb), begin)
            finish = np.where(use_b, pick(fin_b), finish)
            soc = np.where(use_b, pick(soc_b), soc)
            charge_s = np.where(use_b, pick(t_charge), 0.0)
            dock = np.where(use_b, k, -1)
            reach = reach | np.isfinite(a + b).any(axis=1)
            energy_ok = energy_ok | use_b
        else:
            cost = np.where(energy_ok, d1, np.inf)
        code = np.where(~reach, UNREACHABLE, np.where(~energy_ok, ENERGY, np.where(finish > dl, DEADLINE, OK)))
        cost = np.where(code == OK, cost, np.inf)
    return Options(cost, begin, finish, soc, dock, charge_s, code)
