"""One-way corridors (fleet/traffic/lanes.py `one_way`): which one-lane corridors are made one-way, that the
directed graph stays strongly connected, and that two robots meeting head-on across a one-way row never both
enter it (PIBT steps on small grids drawn as text; closed forms, no timing)."""

from __future__ import annotations

import itertools

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from fleet.traffic import PIBT
from fleet.traffic.lanes import DirectedFields, _orient, corridors, one_way

# Two two-wide aisles (x = 0-1, 6-7) joined by three one-lane rows (y = 0, 2, 4); a dead end (x = 8-9, y = 2).
LADDER = """
........
..####..
..........
..####..
........
"""
# Two rooms joined by one corridor: the only link, so it must stay two-way.
DUMBBELL = """
..###..
.......
..###..
"""


def grid(text: str) -> tuple[csr_matrix, np.ndarray, dict[tuple[int, int], int]]:
    """4-connected grid of the '.' cells (row 0 of the text is the top: y = rows - 1)."""
    rows = text.strip("\n").split("\n")
    cells = [(x, len(rows) - 1 - r) for r, line in enumerate(rows) for x, ch in enumerate(line) if ch == "."]
    node = {c: k for k, c in enumerate(cells)}
    edges = [(node[(x, y)], node[(x + dx, y + dy)]) for x, y in cells
             for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)) if (x + dx, y + dy) in node]
    adj = csr_matrix((np.ones(len(edges)), ([a for a, _ in edges], [b for _, b in edges])), shape=(len(cells),) * 2)
    return adj, np.array(cells), node


def strong(adj: csr_matrix) -> int:
    return int(connected_components(adj, directed=True, connection="strong")[0])


def test_through_corridors_found_and_dead_ends_left_out() -> None:
    adj, ij, _ = grid(LADDER)
    rows = sorted(sorted(int(ij[v, 1]) for v in chain) for chain in corridors(adj))
    # the three rows between the aisles (x = 2..5 each); the dead end x = 8-9 is one-lane but not a through way
    assert rows == [[0] * 4, [2] * 4, [4] * 4]
    assert all(sorted(int(ij[v, 0]) for v in chain) == [2, 3, 4, 5] for chain in corridors(adj))


def test_one_way_keeps_the_graph_strongly_connected() -> None:
    adj, ij, node = grid(LADDER)
    out, chains = one_way(adj, ij)
    assert strong(adj) == 1 and strong(out) == 1
    assert len(chains) == 3
    east = [int(ij[c[0], 1]) for c in chains if ij[c[-1], 0] > ij[c[0], 0]]
    # even rows run +x (highways); corridors are taken in node order (top row first), so y = 4 and 2 go east, and
    # y = 0 east too would leave no way west: it runs west
    assert east == [4, 2]
    a = out.toarray()
    for chain in chains:
        for u, v in itertools.pairwise(chain):
            assert a[u, v] > 0 and a[v, u] == 0  # along the chain only
    # the mouths: the exit cell of the y = 2 row is not entered from the aisle, the entry cell does not lead out
    assert a[node[(6, 2)], node[(5, 2)]] == 0 and a[node[(5, 2)], node[(6, 2)]] > 0
    assert a[node[(2, 2)], node[(1, 2)]] == 0 and a[node[(1, 2)], node[(2, 2)]] > 0
    assert a[node[(8, 2)], node[(9, 2)]] > 0 and a[node[(9, 2)], node[(8, 2)]] > 0  # the dead end stays two-way


def test_orienting_a_corridor_removes_exactly_its_reverse_moves_and_mouths() -> None:
    adj, _, _ = grid(LADDER)
    for chain, forward in itertools.product(corridors(adj), (True, False)):
        c = chain if forward else chain[::-1]
        ref = adj.toarray()
        for u, v in itertools.pairwise(c):
            ref[v, u] = 0.0
        outside = [u for u in np.flatnonzero(ref[c[0]]).tolist() if u not in c]
        ref[c[0], outside] = 0.0
        for u in np.flatnonzero(adj.toarray()[c[-1]]).tolist():
            if u not in c:
                ref[u, c[-1]] = 0.0
        out = _orient(adj, chain, forward)
        assert np.array_equal(out.toarray(), ref) and out.nnz == np.count_nonzero(ref)


def test_a_map_with_many_corridors_makes_each_one_way_and_stays_connected() -> None:
    rungs = 40  # two two-wide rails joined by 40 one-lane rungs of 4 cells
    text = "\n".join(["." * (2 * rungs + 1)] * 2 + [" " + ". " * rungs] * 4 + ["." * (2 * rungs + 1)] * 2)
    adj, ij, _ = grid(text.replace(" ", "#"))
    out, chains = one_way(adj, ij)
    assert len(corridors(adj)) == rungs and len(chains) == rungs and strong(out) == strong(adj) == 1
    # each rung loses its 3 reverse moves and its 2 wrong-way mouth moves
    assert adj.nnz - out.nnz == rungs * (3 + 2)


def test_the_only_link_between_two_rooms_stays_two_way() -> None:
    adj, ij, _ = grid(DUMBBELL)
    assert len(corridors(adj)) == 1
    out, chains = one_way(adj, ij)
    assert chains == [] and (out != adj).nnz == 0


def test_robots_meeting_head_on_never_share_the_one_way_row() -> None:
    """A runs (0, 2) → (7, 2) along the east-bound middle row; B runs (7, 2) → (0, 2). Two-way, B would take the
    middle row too (the shortest way) and one would push the other back; one-way, B goes round by the west-bound
    row y = 0 (2 + 7 + 2 = 11 cells) and both arrive without either stepping back."""
    adj, ij, node = grid(LADDER)
    out, _ = one_way(adj, ij)
    fields = DirectedFields(out)
    neighbours = [out.indices[out.indptr[v]:out.indptr[v + 1]].tolist() for v in range(out.shape[0])]
    pibt = PIBT(neighbours, fields.to, 0)
    cur, goals = [node[(0, 2)], node[(7, 2)]], [node[(7, 2)], node[(0, 2)]]
    assert fields.to(goals[1])[cur[1]] == 11
    middle = {node[(x, 2)] for x in range(2, 6)}
    steps = 0
    while cur != goals and steps < 30:
        steps += 1
        before = [fields.to(g)[c] for g, c in zip(goals, cur, strict=True)]
        nxt = pibt.step(cur, goals, np.array([2.0, 1.0]))
        assert len(set(nxt)) == 2 and not (nxt[0] == cur[1] and nxt[1] == cur[0])
        assert all(v == c or v in neighbours[c] for v, c in zip(nxt, cur, strict=True))  # along the edges only
        cur = nxt
        assert not (cur[0] in middle and cur[1] in middle)
        assert all(fields.to(g)[c] < b for g, c, b in zip(goals, cur, before, strict=True) if b > 0)  # no step back
    assert cur == goals and steps == 11


def test_a_pushed_robot_is_never_pushed_into_a_one_way_corridor_that_leads_away() -> None:
    """B rests at node 1 (its goal); A wants node 1. B's only free neighbour is 3, the mouth of the one-way
    corridor 3 → 4 → 2, which would take it 3 cells round to where it stands (0 holds C, frozen; 2 is A's).
    Without traps B is pushed in; with them B stays and A waits (it has no other node)."""
    neighbours = [[1], [0, 2, 3], [1], [4], [2]]
    to_1 = np.array([1.0, 0.0, 1.0, 3.0, 2.0])
    to_0 = np.array([0.0, 1.0, 2.0, 4.0, 3.0])
    fields = {0: to_0, 1: to_1}
    pibt = PIBT(neighbours, fields.__getitem__, 0)
    pibt.push_frozen = False  # C is an obstacle
    cur, goals, priority = [2, 1, 0], [1, 1, 0], np.array([2.0, 1.0, 0.5])
    assert pibt.step(cur, goals, priority, frozen=[2]) == [1, 3, 0]  # pushed into the corridor
    pibt.traps = {3, 4}
    assert pibt.step(cur, goals, priority, frozen=[2]) == [2, 1, 0]  # not: A waits
    goals = [1, 4, 0]  # the corridor is B's way now (4 is its goal): it may go in
    fields[4] = np.array([3.0, 2.0, 3.0, 1.0, 0.0])
    assert pibt.step(cur, goals, priority, frozen=[2]) == [1, 3, 0]
