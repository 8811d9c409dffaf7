"""Traffic layer, asynchronous execution (fleet/traffic): a cycle of robots that deadlocks under naive
execution completes; a slowed and a held robot change neither the planned order in any cell nor the distance
kept (both checked from ground-truth poses after every physics step, independently of the layer); every task
of a small random lifelong instance arrives; deadlock events name robots and how they were resolved; the
mission `traffic:` key with `traffic_go` tasks."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pytest
import yaml

from fleet import Event, FleetConfig, FleetService
from fleet.missions.batch import RunRequest, run_file
from fleet.traffic import TrafficManager, enable_traffic
from sim import Pose2D
from sim.sdf_primitives import box, enclosure, ground_plane
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription
from tests.fleet.traffic_util import Naive


def world(tmp: Path, name: str, half: tuple[float, float], shelves: Sequence[tuple[float, float, float, float]] = ()
          ) -> Path:
    """A walled room, inner faces at ±half (half + 0.2 m wall a whole number: 1 m cells centred on x.5)."""
    models = [ground_plane(size=16), *enclosure(*half),
              *(box(f"shelf{k}", (sx, sy, 1.0), x, y) for k, (x, y, sx, sy) in enumerate(shelves))]
    path = tmp / f"{name}.world"
    save_sdf(WorldDescription(name=name, models=tuple(models)), str(path))
    return path


class Truth:
    """Ground-truth check after every physics step: closest footprint gap between robots and to walls, and the
    order in which robots' centres enter each traffic cell."""

    def __init__(self, svc: FleetService, tm: TrafficManager) -> None:
        self.svc, self.tm = svc, tm
        self.clearance = svc.static_clearance()
        self.pair = self.wall = np.inf
        poses = {n: svc.world.robot_pose(n) for n in tm.names}
        self.cell = {n: tm.grid.node_at(p.x, p.y) for n, p in poses.items()}
        self.entries: dict[int, list[str]] = {}
        svc.step_listeners.append(self)

    def __call__(self) -> None:
        f, r = self.svc.world.table.f, self.tm.radius
        xy = np.column_stack([f["x"], f["y"]])
        d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
        d[np.diag_indices(len(xy))] = np.inf
        self.pair = min(self.pair, float(d.min()) - 2 * r)
        self.wall = min(self.wall, float(self.clearance.query(xy)[0].min()) - r)
        for name, (x, y) in zip(self.svc.world.table.names, xy, strict=True):
            c = self.tm.grid.node_at(float(x), float(y))
            if c != self.cell.get(name) and c >= 0:
                self.entries.setdefault(c, []).append(name)
                self.cell[name] = c


def run_until(svc: FleetService, tm: TrafficManager, done: Callable[[], bool], limit: float) -> float:
    t = 0.0
    while t < limit and not done():
        svc.advance(2.0)
        t += 2.0
    return t


def cycle(tmp: Path, naive: bool) -> tuple[TrafficManager, Truth, list[Event]]:
    """Four robots on a 2 × 2 block of cells, each to the next cell round the block (all occupied): a cycle
    of waits for naive execution. The room has a free 2 × 2 block beside it."""
    ring = [(-1.5, -0.5), (-0.5, -0.5), (-0.5, 0.5), (-1.5, 0.5)]
    with FleetService(FleetConfig(world=str(world(tmp, "ring", (2.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc:
        for k, (x, y) in enumerate(ring):
            svc.spawn_robot(f"c{k}", Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=4.0)
        if naive:
            tm.pibt = Naive(tm)  # type: ignore[assignment]
        for k in range(4):
            tm.add(f"c{k}")
        truth = Truth(svc, tm)
        for k in range(4):
            tm.go(f"c{k}", *ring[(k + 1) % 4])
        run_until(svc, tm, lambda: tm.stats["reached"] >= 4 and not tm.active_count(), 60.0 if naive else 240.0)
        return tm, truth, svc.events.since(0, kinds=["deadlock", "deadlock_resolved"], limit=10_000)


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("traffic_async")


def test_a_cycle_that_deadlocks_naive_execution_completes(tmp: Path) -> None:
    tm, truth, events = cycle(tmp, naive=True)
    assert tm.stats["reached"] == 0 and tm.stats["moves"] == 0  # everyone waits on the next: a cycle
    opened = [e for e in events if e.kind == "deadlock"]
    assert len(opened) == 4 and tm.open_stalls and not tm.stats["resolved"]
    for e in opened:  # each names itself and the robot in the cell it waits for (the next one round)
        k = int(e.robots[0][1:])
        assert f"c{(k + 1) % 4}" in e.robots[1:], e
        assert "resolution" in e.message and e.data["strategy"] == "adg_pibt"

    tm, truth, events = cycle(tmp, naive=False)
    assert tm.stats["reached"] >= 4 and tm.active_count() == 0, tm.describe()
    assert [tm.a[tm.names.index(f"c{k}")] for k in range(4)] == [tm.goal[k] for k in range(4)]
    assert tm.stats["pushes"] > 0  # priority inheritance broke the cycle (via the free block)
    assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
    opened_by = {e.robots[0]: e for e in events if e.kind == "deadlock"}
    closed = {e.robots[0]: e for e in events if e.kind == "deadlock_resolved"}
    assert set(opened_by) == set(closed) and not tm.open_stalls  # every wait it reported, it resolved
    for name, e in closed.items():
        assert e.data["duration"] >= 4.0 and e.robots[0] == name and "again after" in e.message


def corridor(tmp: Path, delays: bool) -> tuple[TrafficManager, Truth]:
    """8 robots swap two 2 × 4-cell rooms through a one-lane corridor; optionally one runs at 30 % speed and
    another is held still for 8 s mid-run."""
    models_half = (5.8, 2.8)
    path = world(tmp, "corridor", models_half, [(0.0, 1.9, 4.0, 1.8), (0.0, -1.4, 4.0, 2.8)])
    left = [(-4.5, -1.5), (-4.5, 1.5), (-3.5, -0.5), (-2.5, 1.5)]
    starts = left + [(-x, y) for x, y in left]
    with FleetService(FleetConfig(world=str(path), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        for k, (x, y) in enumerate(starts):
            svc.spawn_robot(f"r{k}", Pose2D(x, y, 0.0))
        tm = enable_traffic(svc, cell=1.0, speed=0.6, record=True)
        for k in range(len(starts)):
            tm.add(f"r{k}")
        truth = Truth(svc, tm)
        for k, (x, y) in enumerate(starts):
            tm.go(f"r{k}", -x, y)
        if delays:
            tm.set_speed_scale("r2", 0.3)
            svc.advance(4.0)
            tm.hold_robot("r6", 8.0)
        run_until(svc, tm, lambda: tm.stats["reached"] >= 8 and not tm.active_count(), 400.0)
        return tm, truth


def test_slow_and_held_robots_keep_the_planned_order_and_distance(tmp: Path) -> None:
    tm, truth = corridor(tmp, delays=True)
    assert tm.stats["reached"] >= 8 and tm.active_count() == 0, tm.describe()
    assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
    planned: dict[int, list[str]] = {}
    for cell, i in tm.sched.planned_entries:
        planned.setdefault(cell, []).append(tm.names[i])
    assert truth.entries and set(truth.entries) <= set(planned)
    for cell, seen in truth.entries.items():  # ground-truth entries follow the schedule's order in every cell
        assert seen == planned[cell], (cell, seen, planned[cell])


def test_every_task_of_a_small_random_lifelong_instance_arrives(tmp: Path) -> None:
    # Shelves leave no dead end (PIBT's completeness needs every edge on a cycle; see fleet/traffic/pibt.py).
    shelves = [(-2.0, 1.5, 2.0, 0.2), (2.0, 1.5, 2.0, 0.2), (-2.0, -1.5, 2.0, 0.2), (2.0, -1.5, 2.0, 0.2)]
    path = world(tmp, "shop", (4.8, 3.8), shelves)
    rng = np.random.default_rng(3)
    with FleetService(FleetConfig(world=str(path), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        tm = enable_traffic(svc, cell=1.0, speed=0.7, stall_s=5.0)
        cells = rng.choice(len(tm.grid), 6, replace=False)
        names = [f"w{k}" for k in range(6)]
        for name, c in zip(names, cells.tolist(), strict=True):
            x, y = tm.grid.xy[c]
            svc.spawn_robot(name, Pose2D(float(x), float(y), 0.0))
            tm.add(name)
        truth = Truth(svc, tm)
        rounds = [cells]  # three rounds of goals, distinct within a round, none where the robot stands then
        while len(rounds) < 4:
            g = rng.permutation(len(tm.grid))[:6]
            if not np.any(g == rounds[-1]):
                rounds.append(g)
        goals = {n: [int(r[k]) for r in rounds[:0:-1]] for k, n in enumerate(names)}  # popped from the end
        arrived: list[tuple[str, int]] = []

        def reached(name: str, now: float) -> None:
            i = tm.names.index(name)
            arrived.append((name, int(tm.a[i])))
            if goals[name]:
                tm.go(name, *tm.grid.xy[goals[name].pop()])

        tm.on_reached = reached
        for n in names:
            tm.go(n, *tm.grid.xy[goals[n].pop()])
        run_until(svc, tm, lambda: not any(goals.values()) and not tm.active_count(), 400.0)
        assert not any(goals.values()) and tm.active_count() == 0, tm.describe()
        assert len(arrived) == 18 and tm.stats["reached"] == 18
        assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
        assert tm.stats["resolved"] == tm.stats["deadlocks"] and not tm.open_stalls


def test_mission_traffic_key_and_traffic_go_tasks(tmp: Path) -> None:
    world(tmp, "ring", (2.8, 1.8))
    ring = [(-1.5, -0.5), (-0.5, -0.5), (-0.5, 0.5), (-1.5, 0.5)]
    mission = {
        "name": "traffic_ring", "world": "ring.world", "time_limit": 200, "traffic": {"speed": 0.6},
        "physics": {"physics_hz": 20, "control_hz": 10},
        "robots": [{"name": f"c{k}", "pose": {"x": x, "y": y, "yaw": 0.0}} for k, (x, y) in enumerate(ring)],
        "tasks": [{"id": f"go{k}", "robot": f"c{k}", "type": "traffic_go",
                   "params": {"goal": {"x": ring[(k + 1) % 4][0], "y": ring[(k + 1) % 4][1]}}} for k in range(4)],
        "assertions": [{"type": "all_tasks_done", "by": 200}, {"type": "no_collisions"}],
    }
    path = tmp / "traffic_ring.yaml"
    path.write_text(yaml.safe_dump(mission))
    out = run_file(RunRequest(str(path), None, str(tmp / "out"), record=False))
    assert out.passed, out
    with pytest.raises(Exception, match="traffic"):
        bad = dict(mission, traffic={"speed": 0.6, "lanes": 2})
        path.write_text(yaml.safe_dump(bad))
        from fleet.missions import load_mission

        load_mission(path)


def test_traffic_go_through_the_task_queue_and_allocator(tmp: Path) -> None:
    """The door MCP queue_task + assign_tasks uses: the first traffic_go task enables the layer."""
    with FleetService(FleetConfig(world=str(world(tmp, "ring", (2.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc:
        svc.spawn_robot("a", Pose2D(-1.5, -0.5, 0.0))
        svc.spawn_robot("b", Pose2D(1.5, 0.5, 0.0))
        for k, (x, y) in enumerate([(1.5, -0.5), (-1.5, 0.5)]):
            svc.queue_task("traffic_go", {"goal": {"x": x, "y": y}}, id=f"g{k}")
        result = svc.assign_tasks(None, ["a", "b"], "greedy")
        assert len(result.assignments) == 2 and not result.infeasible
        ids = [asg.task_ids[-1] for asg in result.assignments]
        for _ in range(30):
            svc.advance(2.0)
            if all(svc.tasks.tasks[t].state.value == "succeeded" for t in ids):
                break
        assert [svc.tasks.tasks[t].state.value for t in ids] == ["succeeded", "succeeded"]
        poses = sorted((round(p.x, 1), round(p.y, 1)) for p in (svc.world.robot_pose("a"), svc.world.robot_pose("b")))
        assert poses == [(-1.5, 0.5), (1.5, -0.5)]
