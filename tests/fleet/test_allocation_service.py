"""assign_tasks on the façade: grid path costs, dry runs that move nothing, submission into the task queues,
a charge stop inserted and driven end to end, and clear errors."""

import itertools
import math
from contextlib import closing

import numpy as np
import pytest

from fleet import BatteryConfig, FleetConfig, FleetError, FleetService
from sim import Pose2D

from .test_tasks_dock import dock_world

GOALS = [(4.0, 4.0), (-4.5, -2.0), (4.0, -4.0)]


@pytest.fixture(scope="module")
def arena():
    s = FleetService(FleetConfig(world="robot_arena"))
    for name, (x, y) in {"a": (-5.0, -5.0), "b": (5.0, 5.0), "c": (5.0, -5.0)}.items():
        s.spawn_robot(name, Pose2D(x, y, 0.0))
    yield s
    s.close()


def goto(x, y, **kw):
    return {"type": "go_to", "params": {"goal": {"x": x, "y": y}}, **kw}


def test_path_costs_go_around_walls_and_straight_lines_do_not(arena):
    # a at (−5, −5) to (−4.5, −2): the wall along y ≈ −3.3 (x < 3.3) is between them
    path = arena.assign_tasks([goto(-4.5, -2.0)], robots=["a"], dry_run=True)
    line = arena.assign_tasks([goto(-4.5, -2.0)], robots=["a"], dry_run=True, cost="euclidean")
    assert line.travel_m == pytest.approx(math.hypot(0.5, 3.0))
    assert path.travel_m > 2 * line.travel_m  # the way round the end of the wall
    pts = path.assignments[0].path
    assert np.allclose(pts[0], (-5.0, -5.0)) and np.allclose(pts[-1], (-4.5, -2.0))
    assert path.travel_m == pytest.approx(np.hypot(*np.diff(pts, axis=0).T).sum(), rel=0.05)  # the polyline
    cm = arena.costmap_for("a")
    dense = np.vstack([np.linspace(p, q, 20) for p, q in itertools.pairwise(pts[1:-1])])
    assert cm.is_free_many(dense).mean() > 0.95  # the simplified path runs through free space


def test_grid_cost_in_open_space_is_the_straight_line_within_grid_error():
    with closing(FleetService(FleetConfig(world="empty"))) as s:
        s.spawn_robot("r", Pose2D(-3.0, -3.0, 0.0))
        a = s.assign_tasks([goto(3.0, 2.0)], dry_run=True)
        d = math.hypot(6.0, 5.0)
        assert d - 0.3 <= a.travel_m <= d * 1.082 + 0.3  # 8-connected: ≤ 8.2 % longer, ± a cell at each end


def test_hungarian_with_path_costs_matches_brute_force(arena):
    tasks = [goto(x, y) for x, y in GOALS]
    a = arena.assign_tasks(tasks, dry_run=True)
    cost = {(r, t): arena.assign_tasks([tasks[t]], robots=[r], dry_run=True).travel_m
            for r in "abc" for t in range(3)}
    brute = min(sum(cost[(p[t], t)] for t in range(3)) for p in itertools.permutations("abc"))
    assert a.travel_m == pytest.approx(brute, rel=1e-6)


def test_dry_run_moves_nothing_and_submits_nothing(arena):
    before = arena.snapshot.pose.copy()
    for method in ("hungarian", "auction", "greedy"):
        a = arena.assign_tasks([goto(x, y) for x, y in GOALS], method=method, dry_run=True)
        assert a.dry_run and len(a.assignments) == 3 and all(not x.task_ids for x in a.assignments)
        assert a.to_dict()["assignments"][0]["eta_s"] > 0
    arena.advance(1.0)
    assert not arena.list_tasks()
    assert np.allclose(arena.snapshot.pose, before, atol=1e-6)


def test_errors_name_what_is_valid(arena):
    with pytest.raises(FleetError) as err:
        arena.assign_tasks([goto(0, 0)], robots=["a", "zz"], dry_run=True)
    assert err.value.code.value == "UNKNOWN_ROBOT" and "b" in err.value.hint
    with pytest.raises(FleetError) as err:
        arena.assign_tasks([goto(0, 0)], method="vickrey", dry_run=True)
    assert "auction" in err.value.hint and "hungarian" in err.value.hint
    for robot_bound in ({"type": "wait", "params": {"seconds": 1}}, {"type": "return_home"}):
        with pytest.raises(FleetError) as err:
            arena.assign_tasks([robot_bound], dry_run=True)
        assert err.value.code.value == "UNSUPPORTED" and "go_to" in err.value.hint
    with pytest.raises(FleetError, match="deadlin"):
        arena.assign_tasks([{"type": "go_to", "params": {"goal": [0, 0]}, "deadlin": 3}], dry_run=True)


def test_assigned_tasks_run_and_infeasible_ones_stay_queued():
    with closing(FleetService(FleetConfig(world="empty"))) as s:
        s.spawn_robot("r1", Pose2D(-3.0, 0.0, 0.0))
        s.spawn_robot("r2", Pose2D(3.0, 0.0, 0.0))
        s.queue_task("go_to", {"goal": [-3.0, 3.0]}, id="near_r1")
        s.queue_task("go_to", {"goal": [3.0, -3.0]}, id="near_r2", earliest_start=2.0)
        s.queue_task("go_to", {"goal": [0.0, 4.0]}, id="too_late", deadline=1.0)
        a = s.assign_tasks(method="auction")
        assert {x.request: x.robot for x in a.assignments} == {"near_r1": "r1", "near_r2": "r2"}
        assert [i.request for i in a.infeasible] == ["too_late"]
        assert [q["id"] for q in s.unassigned_tasks()] == ["too_late"]  # reported and kept, not dropped
        assert any(e.kind == "tasks_assigned" for e in s.events.since(0))
        s.advance(1.0)
        assert s.robot("r2").pose.distance_to(Pose2D(3.0, 0.0)) < 0.01  # held by its window
        s.advance(9.0)
        for x in a.assignments:
            assert s.task_status(x.task_ids[-1])["state"] == "succeeded"
        assert s.robot("r1").pose.distance_to(Pose2D(-3.0, 3.0)) < 0.2
        assert s.robot("r2").pose.distance_to(Pose2D(3.0, -3.0)) < 0.2
        with pytest.raises(FleetError) as err:  # busy robots are not silently re-planned
            s.call(lambda: s.tasks.submit("wait", "r1", {"seconds": 5}))
            s.assign_tasks([goto(0, 0)], robots=["r1"], dry_run=True)
        assert err.value.code.value == "BUSY"


def test_low_robot_charges_first_then_does_the_task(tmp_path):
    battery = BatteryConfig(capacity_wh=1.0, low_threshold=0.3)  # 0.05 of charge per metre
    with closing(FleetService(FleetConfig(world=dock_world(tmp_path), battery=battery))) as s:
        s.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
        s.set_battery("r1", 0.36)  # the 2.5 m task would leave < 0.3
        a = s.assign_tasks([goto(2.5, 0.0)], charge_to=0.95)
        (x,) = a.assignments
        assert x.charge_dock == "dock_east" and len(x.task_ids) == 2
        queued = [t["type"] for t in s.list_tasks("r1")]
        assert queued == ["dock_and_charge", "go_to"]
        for _ in range(60):
            s.advance(1.0)
            if s.task_status(x.task_ids[1])["state"] == "succeeded":
                break
        assert s.task_status(x.task_ids[0])["state"] == "succeeded"
        assert s.task_status(x.task_ids[1])["state"] == "succeeded"
        kinds = [e.kind for e in s.events.since(0) if e.kind in ("docked", "charged", "task_finished")]
        assert kinds == ["docked", "charged", "task_finished", "task_finished"]
        assert s.robot("r1").pose.distance_to(Pose2D(2.5, 0.0)) < 0.2
        assert s.robot("r1").battery >= 0.3
