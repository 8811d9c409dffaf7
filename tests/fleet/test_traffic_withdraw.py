"""Withdrawing unstarted moves from the traffic schedule (fleet/traffic/schedule.py `withdraw_loops`,
fleet/traffic/withdraw.py): closed forms on hand-built schedules, and a randomised check that with withdrawals
mixed into PIBT planning and step-by-step execution no cell is ever entered by two robots, the planned tails
stay distinct and every queue still drains (the action-dependency graph stayed acyclic).

Execution is abstract: a robot that may claim its next cell (Schedule.can_claim) moves there at once."""

from __future__ import annotations

import numpy as np

from fleet.traffic import PIBT
from fleet.traffic.schedule import BIG, Schedule
from fleet.traffic.withdraw import cut_set, flush, free_ahead
from tests.fleet.test_traffic_jam import JUNCTIONS, grid


def schedule(starts: list[int], steps: list[list[int]], n_cells: int = 12) -> Schedule:
    s = Schedule(n_cells)
    for c in starts:
        s.add(c)
    for nxt in steps:
        s.append(np.array(nxt, np.int64))
    return s


def state(s: Schedule) -> tuple[list[list[int]], list[list[int]], list[int]]:
    """Queues (cells), FIFOs and tails: what execution and planning see."""
    return [[c for c, _ in q] for q in s.queue], [list(f) for f in s.fifo], s.tail.tolist()


def drain(s: Schedule, pos: list[int], limit: int = 1000) -> int | None:
    """Rounds until every queue is empty (each round, robots in index order take their next cell when they
    may); None when no robot can move (a cycle in the ADG). Asserts no cell is ever entered by two robots."""
    for rounds in range(limit):
        if not any(s.queue):
            return rounds
        moved = False
        for i in range(len(pos)):
            if s.can_claim(i):
                v, _ = s.claim(i)
                assert v not in pos, f"robot {i} entered cell {v}, held by robot {pos.index(v)}"
                s.depart(i, pos[i])
                s.release(i, pos[i])
                pos[i] = v
                moved = True
        if not moved:
            return None
    return None


def test_a_withdrawn_loop_leaves_the_queues_as_if_it_had_never_been_planned() -> None:
    # Robot 0 at 5 is pushed to 6 and back twice, then goes on to 7; robot 1 (at 4) follows it into 5 after that.
    loop = schedule([5, 4], [[6, 4], [5, 4], [6, 4], [5, 4], [6, 5], [7, 5]])
    never = schedule([5, 4], [[5, 4], [5, 4], [5, 4], [5, 4], [6, 5], [7, 5]])
    assert loop.withdraw_loops(0, 5) == 4
    assert state(loop) == state(never)
    assert loop.head_step[0] == never.head_step[0] == 5
    assert loop.withdraw_loops(0, 5) == 0  # nothing left to withdraw


def test_a_queue_behind_a_detour_drains_in_one_round_once_the_detour_is_withdrawn() -> None:
    # Robot 0 (at 5) has 5 moves back and forth queued, 6 5 6 5 6; robots 1 and 2 queue behind it in the line.
    steps = [[6, 4, 3], [5, 4, 3], [6, 4, 3], [5, 4, 3], [6, 5, 4]]
    kept = schedule([5, 4, 3], steps)
    assert drain(kept, [5, 4, 3]) == 5  # robot 1 enters 5 only when robot 0 has left it for the last time
    cut = schedule([5, 4, 3], steps)
    assert cut.withdraw_loops(0, 5) == 4
    assert state(cut)[0] == [[6], [5], [4]]
    assert drain(cut, [5, 4, 3]) == 1


def test_a_loop_another_robot_is_planned_through_is_kept() -> None:
    # Robot 0 goes 5 -> 6 -> 5, but robot 1 (at 4) passes through 5 while it is away (4 -> 5 -> 7):
    # withdrawing the loop would keep robot 0 in 5, so robot 1 would wait for it for ever.
    s = schedule([5, 4], [[6, 5], [6, 7], [5, 7]])
    before = state(s)
    assert s.withdraw_loops(0, 5) == 0
    assert state(s) == before
    assert drain(s, [5, 4]) == 3  # robot 1 through 5, then out to 7; then robot 0 back into 5


def test_moves_ahead_of_an_urgent_robot_are_cut_with_their_followers_and_only_below_it() -> None:
    # Robot 0 (at 1) is planned into 2, robot 1 (at 0) follows it into 1; robot 2 (at 3) is planned into 2
    # after robot 0. Freeing robot 2 cuts robot 0 back to 1, and so robot 1 back to 0.
    steps = [[2, 0, 3], [2, 1, 3], [2, 1, 2]]
    s = schedule([1, 0, 3], steps)
    here = np.array([1, 0, 3])
    assert cut_set(s, here, {0: 0}, np.array([True, True, False])) == {0: 0, 1: 0}
    assert cut_set(s, here, {0: 0}, np.array([True, False, False])) is None  # robot 1 ranks above: refused
    assert free_ahead(s, here, np.array([1.0, 5.0, 2.0]), [2]) == 0  # the same, through free_ahead
    assert free_ahead(s, here, np.array([1.0, 0.5, 2.0]), [2]) == 2
    assert state(s) == ([[], [], [2]], [[], [], [2]] + [[]] * 9, [1, 0, 2])
    assert s.head_step.tolist() == [BIG, BIG, 3]
    assert drain(s, [1, 0, 3]) == 1


def test_flush_leaves_every_robot_at_its_committed_cell() -> None:
    s = schedule([5, 4, 3], [[6, 4, 3], [5, 4, 3], [6, 5, 4]])
    assert flush(s, np.array([5, 4, 3])) == 5
    assert state(s) == ([[], [], []], [[]] * 12, [5, 4, 3])


def test_withdrawals_mixed_into_pibt_never_put_two_robots_in_a_cell_and_every_queue_drains() -> None:
    neighbours, fields, _ = grid(JUNCTIONS, lanes=True)
    n_cells, withdrawn = len(neighbours), 0
    for trial in range(12):
        rng = np.random.default_rng(trial)
        n = 24  # of 64 cells: a jam
        pos = rng.choice(n_cells, n, replace=False).tolist()
        s = Schedule(n_cells)
        for c in pos:
            s.add(c)
        pibt = PIBT(neighbours, fields.to, trial)
        goals = rng.choice(n_cells, n, replace=False).tolist()
        periods = rng.integers(1, 4, n)
        priority = rng.random(n)
        for t in range(150):
            for i in range(n):  # execution: robots of three speeds
                if t % periods[i] == 0 and s.can_claim(i):
                    v, _ = s.claim(i)
                    assert v not in pos, (trial, t, i, v)
                    s.depart(i, pos[i])
                    s.release(i, pos[i])
                    pos[i] = v
                if pos[i] == goals[i] and not s.queue[i]:
                    goals[i] = int(rng.integers(n_cells))  # lifelong: a new goal (shared goals are fine)
            here = np.array(pos)
            op = int(rng.integers(4))
            if op == 0:
                withdrawn += sum(s.withdraw_loops(i, pos[i]) for i in range(n))
            elif op == 1:
                withdrawn += free_ahead(s, here, rng.random(n), [i for i in range(n) if s.queue[i]])
            elif op == 2 and rng.random() < 0.1:
                withdrawn += flush(s, here)
            assert len(set(s.tail.tolist())) == n, (trial, t)  # the planned configuration has no vertex conflict
            assert all(c == q[-1][0] for c, q in zip(s.tail.tolist(), s.queue, strict=True) if q)
            assert all(s.tail[i] == pos[i] for i in range(n) if not s.queue[i])
            frozen = [i for i in range(n) if s.queue[i]]
            nxt = pibt.step(s.tail.tolist(), goals, priority + (t - np.arange(n)) % 7, frozen)
            s.append(np.array(nxt, np.int64))
        assert drain(s, pos) is not None, trial
    assert withdrawn > 100  # the withdrawals were exercised
