"""Congestion-aware routing (fleet/traffic/congestion.py): the toll on busy cells in closed form, and PIBT on
those fields sending part of a stream of robots round a longer corridor instead of all through the short one
(synchronous PIBT steps, no timing). And the order among urgent robots (manager.py `urgent_rank`)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import csr_matrix

from fleet import FleetConfig, FleetService
from fleet.traffic import PIBT, TrafficManager, enable_traffic
from fleet.traffic.congestion import CongestionFields
from sim import Pose2D
from sim.errors import FleetError
from tests.fleet.test_traffic_async import world
from tests.fleet.test_traffic_jam import grid


def two_ways() -> tuple[csr_matrix, dict[str, int]]:
    """S → a1 → a2 → a3 → G (4 moves) or S → b1 → … → b4 → G (5 moves), every move costing 1 both ways."""
    names = ["S", "a1", "a2", "a3", "b1", "b2", "b3", "b4", "G"]
    k = {n: i for i, n in enumerate(names)}
    path_a, path_b = ["S", "a1", "a2", "a3", "G"], ["S", "b1", "b2", "b3", "b4", "G"]
    edges = [(k[u], k[v]) for p in (path_a, path_b) for u, v in itertools.pairwise(p)]
    r = [u for u, v in edges] + [v for u, v in edges]
    c = [v for u, v in edges] + [u for u, v in edges]
    return csr_matrix((np.ones(len(r)), (r, c)), shape=(len(names), len(names))), k


def test_toll_is_weight_times_recent_occupancy_in_closed_form() -> None:
    adj, k = two_ways()
    f = CongestionFields(adj, weight=4.0, tau=20.0, refresh_s=5.0)
    f.refresh(0.0)
    assert f.to(k["G"])[k["S"]] == 4.0  # no traffic yet: the short way
    busy = np.array([k["a1"], k["a2"], k["a3"]])
    for _ in range(600):  # a1..a3 occupied for 60 s
        f.observe(busy, 0.1)
    occ = 1.0 - math.exp(-60.0 / 20.0)
    assert np.allclose(f.occupancy[busy], occ) and f.occupancy[k["b1"]] == 0.0
    f.refresh(4.0)  # within refresh_s of the last refresh: the cached fields stand
    assert f.to(k["G"])[k["S"]] == 4.0
    f.refresh(60.0)
    to_g = f.to(k["G"])
    # From S: the short way now costs 4 + 3 tolls (entering a1, a2, a3) > 5, so the long way (5) wins.
    assert to_g[k["S"]] == 5.0
    # From a1: on through a2, a3 (3 + 2 tolls) or back to S and round (1 + 5), whichever is cheaper.
    assert math.isclose(to_g[k["a1"]], min(3.0 + 2 * 4.0 * occ, 6.0))
    # From a3 towards S: back through a2, a1 (3 + 2 tolls; S is not tolled) or on to G and round (1 + 5).
    assert math.isclose(f.to(k["S"])[k["a3"]], min(3.0 + 2 * 4.0 * occ, 6.0))
    for _ in range(200):  # 20 s with nobody there: the occupancy decays by e^-1
        f.observe(np.zeros(0, np.int64), 0.1)
    assert np.allclose(f.occupancy[busy], occ * math.exp(-1.0))


# West and east yards (x 0–1 and 9–10, y 0–2) joined by a short corridor (y = 2) and a long one round the
# block (up x = 0, along y = 4, down x = 10: 4 moves longer): the static fields send every robot from the
# west yard to the east yard through the short one.
MAP = ["...........",  # y = 4
       ".#########.",
       "...........",  # y = 2
       "..#######..",
       "..#######.."]


def stream(congestion: float) -> tuple[bool, int, set[int]]:
    """6 robots from the west yard to the east yard; returns (all arrived, steps, long-corridor cells used)."""
    neighbours, fields, node = grid(MAP, lanes=False)
    n = len(neighbours)
    rows = [i for i, nb in enumerate(neighbours) for _ in nb]
    cols = [v for nb in neighbours for v in nb]
    cong = CongestionFields(csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n)), weight=congestion,
                            tau=5.0, refresh_s=1.0)
    pibt = PIBT(neighbours, cong.to if congestion > 0 else fields.to, seed=0)
    starts = [node[(x, y)] for y in range(3) for x in (0, 1)]
    goals = [node[(x, y)] for y in range(3) for x in (10, 9)]
    long_way = {node[(x, 4)] for x in range(1, 10)}
    cur, used = list(starts), set()
    priority = np.arange(len(starts), 0, -1, dtype=float)
    for t in range(200):
        cong.observe(np.array(cur), 1.0)
        cong.refresh(float(t))
        nxt = pibt.step(cur, goals, priority)
        assert len(set(nxt)) == len(nxt), f"vertex conflict at step {t}"
        assert not any(nxt[i] == cur[j] and nxt[j] == cur[i] != nxt[i]
                       for i in range(len(cur)) for j in range(i)), f"swap conflict at step {t}"
        cur = nxt
        used |= set(cur) & long_way
        if cur == goals:
            return True, t + 1, used
        # PIBT's priorities: growing while away from the goal, reset (lowest) at it
        away = np.array(cur) != np.array(goals)
        priority = np.where(away, priority + 1.0, np.arange(len(cur)) * 1e-3)
    return False, 200, used


def test_congestion_sends_part_of_a_stream_round_the_long_corridor() -> None:
    ok, steps_static, used = stream(0.0)
    assert ok and not used, "static fields: everybody through the short corridor"
    ok, steps_cong, used = stream(4.0)
    assert ok and used, "with the toll some robots take the long corridor"
    assert steps_cong < steps_static and steps_cong <= 25, (steps_cong, steps_static)  # 17 vs 34 here


class Recorder:
    """Stands in for PIBT to record the priorities the manager plans with (everybody waits)."""

    def __init__(self) -> None:
        self.priority = np.zeros(0)
        self.pushes: list[tuple[int, int]] = []

    def step(self, cur: Sequence[int], goals: Sequence[int], priority: np.ndarray, frozen: Sequence[int] = (),
             prefer: Sequence[int] | None = None) -> list[int]:
        self.priority = priority.copy()
        return list(cur)


@pytest.mark.parametrize("rank", ["since_progress", "since_urgent"])
def test_urgent_robots_ranked_by_time_without_progress(tmp_path: Path, rank: str) -> None:
    # u0 became urgent first (t = 20) but came closer since (t = 25); u1 became urgent at t = 30, no progress
    # since t = 18 (pushed back, say); n2 is not urgent. At t = 40, since_progress puts u1 (22 s without
    # progress) above u0 (15 s); since_urgent (the fourth landing's rule) keeps u0 (urgent 20 s) above u1 (10 s).
    with FleetService(FleetConfig(world=str(world(tmp_path, "room", (2.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc:
        tm = enable_traffic(svc, cell=1.0, urgent_s=12.0, urgent_rank=rank)
        spots = [(-1.5, -0.5), (0.5, -0.5), (1.5, 0.5)]
        for k, (x, y) in enumerate(spots):
            svc.spawn_robot(f"r{k}", Pose2D(x, y, 0.0))
            tm.add(f"r{k}")
        for k in range(3):
            tm.go(f"r{k}", *spots[(k + 1) % 3])
        rec = Recorder()
        tm.pibt = rec  # type: ignore[assignment]
        tm.urgent_at[:] = [20.0, 30.0, math.inf]
        tm.best_at[:] = [25.0, 18.0, 39.0]
        tm.since[:] = [0.0, 0.0, 0.0]
        tm._plan(40.0)
        p = rec.priority
        assert min(p[0], p[1]) > p[2], "urgent robots outrank the others"
        assert (p[1] > p[0]) == (rank == "since_progress"), p
        with pytest.raises(FleetError, match="urgent_rank"):
            TrafficManager(svc, urgent_rank="oldest")  # type: ignore[arg-type]
