"""The traffic schedule as an action-dependency graph (Hönig et al., "Persistent and robust execution of MAPF
schedules in warehouses", RA-L 2019), kept implicitly as one FIFO per cell.

PIBT plans synchronous steps on the *planned* configuration (each robot's last planned cell, its tail); every
planned move is appended to its robot's queue and to the FIFO of the cell it enters, in plan order. The ADG's
type-1 edges are the order of a robot's own queue; its type-2 edges ("j may enter v only after i, the robot
planned to be in v before j, has left it") are the FIFO order of v plus the holder of v. A robot moves on as
soon as its own next cell is its to claim, not when the fleet has finished a step.

Acyclic by construction: a move at step t depends only on moves at steps < t, or on the move of the robot
leaving the same cell at step t, and PIBT never plans a loop of robots following each other (pibt.py), so
those same-step chains end. Plans are only ever appended, so the graph stays acyclic as it grows, and every
planned move is eventually executed as long as robots move at all (Hönig et al., Theorem 1).

Cell state: `at[v]` is the robot resting in v or heading into it; `leaving[v]` the robot that is leaving v and
is not yet clear of it (it releases v once its footprint is `clear_m` from v's centre, by ground truth).
"""

from __future__ import annotations

from collections import deque

import numpy as np

BIG = np.iinfo(np.int64).max // 2


class Schedule:
    def __init__(self, n_cells: int, record: bool = False) -> None:
        self.at = np.full(n_cells, -1, np.int64)
        self.leaving = np.full(n_cells, -1, np.int64)
        self.fifo: list[deque[int]] = [deque() for _ in range(n_cells)]
        self.queue: list[deque[tuple[int, int]]] = []  # per robot: planned (cell, step) not yet claimed
        self.tail = np.zeros(0, np.int64)  # per robot: last planned cell
        self.before = np.zeros(0, np.int64)  # per robot: the planned cell before its tail (-1: none)
        self.head_step = np.zeros(0, np.int64)  # per robot: plan step of its first queued move (BIG: none)
        self.step = 0  # planned steps so far
        self.record = record
        self.planned_entries: list[tuple[int, int]] = []  # (cell, robot) in plan order, when record is on

    def add(self, cell: int) -> int:
        """A robot at rest in `cell`; returns its index."""
        i = len(self.queue)
        self.queue.append(deque())
        self.tail = np.append(self.tail, cell)
        self.before = np.append(self.before, -1)
        self.head_step = np.append(self.head_step, BIG)
        self.at[cell] = i
        return i

    def remove(self, i: int, cell: int) -> None:
        """Robot i (at rest in `cell`, nothing planned) leaves; higher indices shift down by one."""
        self.at[cell] = -1
        del self.queue[i]
        self.tail = np.delete(self.tail, i)
        self.before = np.delete(self.before, i)
        self.head_step = np.delete(self.head_step, i)
        for arr in (self.at, self.leaving):
            arr[arr > i] -= 1
        for q in self.fifo:
            if q:
                q2 = deque(k - 1 if k > i else k for k in q)
                q.clear()
                q.extend(q2)

    def append(self, nxt: np.ndarray) -> list[int]:
        """One PIBT step from the tails: queue every move; returns the robots that move."""
        self.step += 1
        movers = np.flatnonzero(nxt != self.tail).tolist()
        for i in movers:
            v = int(nxt[i])
            if not self.queue[i]:
                self.head_step[i] = self.step
            self.queue[i].append((v, self.step))
            self.fifo[v].append(i)
            self.before[i] = self.tail[i]
            self.tail[i] = v
            if self.record:
                self.planned_entries.append((v, i))
        return movers

    def can_claim(self, i: int) -> bool:
        """Is robot i's next planned cell its to enter now (first in the cell's FIFO, nobody in or entering it)?"""
        q = self.queue[i]
        if not q:
            return False
        v = q[0][0]
        return self.fifo[v][0] == i and self.at[v] < 0

    def claim(self, i: int) -> tuple[int, int]:
        """Robot i takes its next planned cell (check can_claim first); returns (cell, step)."""
        q = self.queue[i]
        v, step = q.popleft()
        self.head_step[i] = q[0][1] if q else BIG
        self.fifo[v].popleft()
        self.at[v] = i
        return v, step

    def depart(self, i: int, cell: int) -> None:
        """Robot i starts leaving `cell` (it is in or heading into its next one)."""
        if self.at[cell] == i:
            self.at[cell] = -1
        self.leaving[cell] = i

    def release(self, i: int, cell: int) -> None:
        if self.leaving[cell] == i:
            self.leaving[cell] = -1

    @property
    def queued(self) -> np.ndarray:
        """Per robot, planned moves not yet claimed."""
        return np.fromiter((len(q) for q in self.queue), np.int64, len(self.queue))

    def blockers(self, i: int) -> list[int]:
        """The robots robot i waits for to enter its next planned cell (ahead in the FIFO, in or leaving it)."""
        q = self.queue[i]
        if not q:
            return []
        v = q[0][0]
        out = [int(k) for k in (self.at[v], self.leaving[v]) if k >= 0 and k != i]
        for k in self.fifo[v]:
            if k == i:
                break
            out.append(k)
        return sorted(set(out))

    def withdraw_loops(self, i: int, here: int) -> int:
        """Withdraw robot i's planned loops: unstarted moves that bring it back to a cell it is in (`here`: the
        cell it is in or has claimed) or will be in earlier in its queue. The moves from the first visit of X to
        the last are cut, so the robot stays in X instead of going round (a pushed robot's back-and-forth, which
        every robot planned after it through those cells would wait for). Returns the moves withdrawn.

        Safe when no other robot is in X's FIFO between i's first visit and its last: then the ADG without the
        loop has no edge whose endpoints were not already ordered the same way by a path through the loop (a
        FIFO successor of a withdrawn entry now follows the entry before it, which it followed through i; i's
        move out of X after the loop is unchanged), so the graph stays acyclic, every cell is still entered
        one robot at a time, and the robots' tails stay distinct (the loop ends where it began)."""
        q = self.queue[i]
        if len(q) < 2:
            return 0
        cells = [here, *(v for v, _ in q)]
        cut = [False] * len(cells)  # by cell index: queue entry k - 1 withdrawn
        last = {v: k for k, v in enumerate(cells)}
        p = 0
        while p < len(cells) - 1:
            r = last[cells[p]]
            if r > p and self._loop_alone(i, cells, cut, p, r):
                for k in range(p + 1, r + 1):
                    cut[k] = True
                p = r
            p += 1
        if not any(cut):
            return 0
        drop: dict[int, set[int]] = {}  # cell -> ranks of i's entries into it to withdraw
        seen: dict[int, int] = {}
        for k in range(1, len(cells)):
            v = cells[k]
            rank = seen.get(v, 0)
            seen[v] = rank + 1
            if cut[k]:
                drop.setdefault(v, set()).add(rank)
        for v, ranks in drop.items():
            kept: deque[int] = deque()
            rank = 0
            for k in self.fifo[v]:
                if k == i:
                    rank += 1
                    if rank - 1 in ranks:
                        continue
                kept.append(k)
            self.fifo[v] = kept
        kept_moves = [m for k, m in enumerate(q, 1) if not cut[k]]
        q.clear()
        q.extend(kept_moves)
        self.head_step[i] = q[0][1] if q else BIG
        if cut[-1]:  # the tail is unchanged (the loop ended where it began); the cell before it is not
            prev = [c for k, c in enumerate(cells[:-1]) if not cut[k]]
            self.before[i] = prev[-2] if len(prev) >= 2 else -1
        return sum(cut)

    def _loop_alone(self, i: int, cells: list[int], cut: list[bool], p: int, r: int) -> bool:
        """Is nobody else in the FIFO of X = cells[p] between i's entry at p (or the start, when i holds X) and
        its entry at r?"""
        x = cells[p]
        first = sum(1 for k in range(1, p + 1) if cells[k] == x)  # i's entries into X up to p (0 when p = 0)
        last = first + sum(1 for k in range(p + 1, r + 1) if cells[k] == x)
        rank = 0
        for k in self.fifo[x]:
            if k == i:
                rank += 1
                if rank == last:
                    return True
            elif rank >= first:
                return False
        return False
