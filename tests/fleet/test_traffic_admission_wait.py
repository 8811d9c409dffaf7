"""Admission driven by the wait bound (fleet/traffic/admission_wait.py, `admission: bound`): a held goal whose way
crosses the way of a robot in a wait stays held, in order, while later held goals elsewhere start; in closed form
on a line graph, and through the layer on the corridor world (a robot starved in front of the corridor: the held
goal through the corridor waits, the one inside the room starts)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import enable_traffic
from fleet.traffic.admission import Admission, Held
from fleet.traffic.admission_wait import BoundAdmission, reach_cells, way
from sim import Pose2D
from tests.fleet.test_traffic_corridor import corridor_world


def test_way_follows_the_steepest_descent_for_reach_cells() -> None:
    nb = [[1], [0, 2], [1, 3], [2, 4], [3]]  # a line 0 – 4, goal 4
    to_goal = np.array([4.0, 3.0, 2.0, 1.0, 0.0])
    assert way(nb, to_goal, 0, 3) == [1, 2, 3]
    assert way(nb, to_goal, 0, 10) == [1, 2, 3, 4]  # ends at the goal
    assert way(nb, to_goal, 4, 3) == []
    assert reach_cells(10.0, 0.8) == 16 and reach_cells(10.0, 0.6) == 12  # (30 − 10) s at the peak speed
    assert reach_cells(40.0, 0.8) == 1


def test_held_goals_crossing_a_starved_way_stay_held_in_order() -> None:
    cells = {"r0": [5], "r1": [1], "r2": [5, 6], "r3": [2], "r4": [3]}
    goals = [Held(r, 0.0, 0.0, float(k)) for k, r in enumerate(cells)]
    plain = Admission(limit=3)
    plain.queue.extend(goals)
    assert [h.robot for h in plain.admit(active=0, now=10.0)] == ["r0", "r1", "r2"]  # FIFO, blind to the wait
    adm = BoundAdmission(limit=2)
    adm.queue.extend(goals)
    adm.crosses = lambda h: cells[h.robot]
    adm.hot = {5}  # a starved robot's way
    assert [h.robot for h in adm.admit(active=0, now=10.0)] == ["r1", "r3"]
    assert [h.robot for h in adm.queue] == ["r0", "r2", "r4"]  # kept, in order, ahead of the rest
    assert adm.stats["deferred"] == 2 and adm.stats["admitted"] == 2
    adm.hot.clear()  # the wait is over: FIFO again
    assert [h.robot for h in adm.admit(active=0, now=11.0)] == ["r0", "r2"]


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("admission_wait")


def test_layer_keeps_the_goal_through_a_starved_robots_corridor_held(tmp: Path) -> None:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = {"r0": (-2.5, 0.5), "r1": (-4.5, -1.5), "r2": (-4.5, 1.5)}
        for name, (x, y) in starts.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0, admission="bound")
        adm = tm.admission
        assert isinstance(adm, BoundAdmission) and adm.starve_s == 5.0  # half of stall_s
        adm.limit, adm._next = 1, math.inf  # a fixed limit (the AIMD step is park's, test_traffic_admission.py)

        def setup() -> None:
            for name in starts:
                tm.add(name)
            tm.go("r0", 2.5, 0.5)  # through the corridor: started
            tm.go("r1", 4.5, -1.5)  # through the corridor too: held
            tm.go("r2", -4.5, -0.5)  # within the left room: held
            adm.limit = 2
            tm.best_at[tm._idx["r0"]] = svc.world.time - 15.0  # r0 in a wait for 15 s
            tm._admit(svc.world.time)

        svc.call(setup)
        assert tm.held("r1") and not tm.held("r2") and tm.active_count() == 2
        assert tm.grid.node_at(0.5, 0.5) in adm.hot  # the corridor lies on r0's way
        svc.call(lambda: tm.best_at.__setitem__(tm._idx["r0"], svc.world.time))  # r0 came closer: no wait
        adm.limit = 3
        svc.call(lambda: tm._admit(svc.world.time))
        assert not tm.held("r1") and not adm.hot and tm.active_count() == 3


def test_bound_limit_is_fixed_at_a_tenth_of_the_free_cells() -> None:
    from fleet.traffic.admission import layer_admission

    adm = layer_admission("bound", 10.0, 965)
    assert isinstance(adm, BoundAdmission) and adm.limit == 96.5 and adm.starve_s == 5.0
    small = layer_admission("bound", 10.0, 28)
    assert small is not None and small.limit == 20.0  # never below 1 / the stalled share (0.05)
    adm.queue.append(Held("r", 0.0, 0.0, 0.0))
    plain = Admission(stalled_share=0.05, limit=96.5)
    for now, stalled in ((0.0, 30), (20.0, 0), (40.0, 0)):  # a cut, then two periods without waits
        plain.update(now, active=96, stalled=stalled)
        adm.update(now, active=96, stalled=stalled)
    assert plain.limit == 69  # AIMD: cut to 0.7 · 96 = 67, then + 1 per period while it binds
    assert adm.limit == 96.5 and adm.stats["decreases"] == 0  # bound: neither cut nor grown


def test_crowded_flushes_planned_moves_only_while_goals_are_held(tmp: Path) -> None:
    """`withdraw: crowded` (the default): every unstarted move is withdrawn each flush_s while admission holds a
    goal, and none once nothing is held."""
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = {"r0": (-4.5, -1.5), "r1": (-4.5, 1.5)}
        for name, (x, y) in starts.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, window=3)  # three moves planned ahead: some unstarted
        adm = tm.admission
        assert tm.withdraw == "crowded" and isinstance(adm, BoundAdmission)

        def setup() -> None:
            for name in starts:
                tm.add(name)
            adm.limit = 1
            tm.go("r0", 4.5, 1.5)  # through the corridor: started
            tm.go("r1", -2.5, -1.5)  # held (limit 1)

        svc.call(setup)
        svc.advance(4.0)
        assert tm.held("r1") and tm.stats["withdrawn"] > 0  # crowded: r0's unstarted moves re-planned each second
        adm.limit = 2
        svc.advance(0.5)  # r1 admitted: nothing held
        assert not tm.held("r1")
        before = tm.stats["withdrawn"]
        svc.advance(4.0)
        assert tm.stats["withdrawn"] == before and tm.stats["steps"] > 0  # not crowded: plans kept
