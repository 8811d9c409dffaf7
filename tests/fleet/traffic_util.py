"""A naive planner for the traffic layer's tests: the baseline PIBT is compared against on the same grid and
executor."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fleet.traffic import TrafficManager


class Naive:
    """Each robot takes its best neighbour if nobody is in it, else waits: no priority inheritance."""

    def __init__(self, tm: TrafficManager) -> None:
        self.tm = tm
        self.pushes: list[tuple[int, int]] = []

    def step(self, cur: Sequence[int], goals: Sequence[int], priority: np.ndarray, frozen: Sequence[int] = (),
             prefer: Sequence[int] | None = None) -> list[int]:
        nxt, taken = list(cur), set(cur)
        for i in np.argsort(-priority).tolist():
            field = self.tm.grid.fields.to(goals[i])
            best = min([cur[i], *self.tm.grid.neighbours[cur[i]]], key=lambda v: field[v])
            if i not in frozen and best not in taken:
                taken.add(best)
                nxt[i] = best
        return nxt
