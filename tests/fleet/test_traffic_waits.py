"""Traffic-layer waits (fleet/traffic/pibt.py `yield_aside`): the head-on pattern behind the long waits of the
warehouse runs. A low-priority robot meets a higher-priority one head-on in a one-lane aisle that has side
pockets; pushed, it used to pick back or aside at random (equally far from its goal) and could be pushed back
cell after cell. Yielding off the pusher's way it steps into the pocket once and is on its way again after the
other has passed. Steps are synchronous PIBT steps (sim time in steps), no timing."""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix

from fleet.traffic import PIBT
from fleet.traffic.lanes import DirectedFields, highways
from planning.distance_fields import DistanceFields

LENGTH = 12  # aisle cells 0..11 along x; pockets above cells 2, 5 and 8 (nodes LENGTH + k)
POCKETS = (2, 5, 8)


def aisle() -> tuple[list[list[int]], DistanceFields]:
    edges = [(k, k + 1) for k in range(LENGTH - 1)] + [(x, LENGTH + k) for k, x in enumerate(POCKETS)]
    n = LENGTH + len(POCKETS)
    r = [a for a, b in edges] + [b for a, b in edges]
    c = [b for a, b in edges] + [a for a, b in edges]
    adj = csr_matrix((np.ones(len(r)), (r, c)), shape=(n, n))
    return [adj.indices[adj.indptr[i]:adj.indptr[i + 1]].tolist() for i in range(n)], DistanceFields(adj)


def longest_wait(yield_aside: bool, seed: int) -> tuple[int, list[int], bool]:
    """Robot 0 (higher priority) runs 11 → 0; robot 1 runs 3 → 11 and meets it head-on. Returns robot 1's
    longest run of steps without coming closer to its goal, its cells, and whether both arrived."""
    neighbours, fields = aisle()
    pibt = PIBT(neighbours, fields.to, seed)
    pibt.yield_aside = yield_aside
    cur, goals = [LENGTH - 1, 3], [0, LENGTH - 1]
    priority = np.array([2.0, 1.0])
    best, since, longest, cells = fields.to(goals[1])[cur[1]], 0, 0, [cur[1]]
    for step in range(1, 60):
        nxt = pibt.step(cur, goals, priority)
        assert len(set(nxt)) == len(nxt), "vertex conflict"
        assert not (nxt[0] == cur[1] and nxt[1] == cur[0]), "swap conflict"
        cur = nxt
        cells.append(cur[1])
        d = fields.to(goals[1])[cur[1]]
        if d < best:
            best, since = d, step
        longest = max(longest, step - since)
        if cur == goals:
            return longest, cells, True
    return longest, cells, False


def test_pushed_robot_steps_aside_and_waits_briefly() -> None:
    for seed in range(12):
        longest, cells, arrived = longest_wait(True, seed)
        # pushed back one cell to the pocket beside it, aside while the other passes, back to where it was
        # (5 steps): never pushed further back along the aisle
        assert arrived and longest <= 5, (seed, cells)
        assert cells[:9] == [3, 4, 5, 6, 6, 5, LENGTH + 1, 5, 6], (seed, cells)


def test_without_yield_aside_it_is_pushed_back_along_the_aisle() -> None:
    """The pattern reproduced: with a random choice between back and aside, some seeds push it back to the
    next pocket (wait 11 steps) or into the dead end at cell 0, where it blocks the other's goal for good."""
    runs = [longest_wait(False, seed) for seed in range(12)]
    assert any(w > 5 and arrived for w, _, arrived in runs), runs
    assert any(not arrived and cells[-1] == 0 for _, cells, arrived in runs), runs


def test_highway_costs_follow_the_lanes() -> None:
    """lanes.highways on a 3 × 2 grid: even rows run +x, odd rows -x, even columns +y, odd columns -y; a move
    against its lane costs `against` times its cost, one with it is unchanged."""
    ij = np.array([[x, y] for x in range(3) for y in range(2)])  # node = 2x + y
    edges = [(a, b) for a in range(6) for b in range(6) if np.abs(ij[a] - ij[b]).sum() == 1]
    adj = csr_matrix((np.ones(len(edges)), ([a for a, _ in edges], [b for _, b in edges])), shape=(6, 6))
    out = highways(adj, ij, 4.0).toarray()
    assert out[0, 2] == 1.0 and out[2, 0] == 4.0  # row y=0 runs +x
    assert out[3, 1] == 1.0 and out[1, 3] == 4.0  # row y=1 runs -x
    assert out[0, 1] == 1.0 and out[1, 0] == 4.0  # column x=0 runs +y
    assert out[3, 2] == 1.0 and out[2, 3] == 4.0  # column x=1 runs -y
    fields = DirectedFields(csr_matrix(out))
    # to node 0 from node 4 (x=2, y=0): against row 0 twice (8), or 4 → 5 (+y, 1), 5 → 3 → 1 (-x, 2),
    # 1 → 0 (-y on column 0: against, 4) = 7
    assert fields.to(0)[4] == 7.0
