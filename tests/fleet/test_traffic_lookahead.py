"""An urgent robot's look-ahead (manager.py `urgent_window`, priority.lookahead): it plans `urgent_window` moves
ahead while the others plan `window`, and the layer stays safe and live with it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import TrafficManager, enable_traffic
from sim import Pose2D
from sim.errors import FleetError
from tests.fleet.test_traffic_async import Truth, world

ROW = -0.5  # the south row of the room (tests/fleet/test_traffic_urgency.py's)


def drive_urgent(tmp: Path, urgent_window: int) -> dict[str, float]:
    """r0 made urgent at the west end of the south row, its goal 7 cells east, and r2 sent east along the north
    row (not urgent): the most moves each had queued, and r0's arrival (sim s)."""
    with FleetService(FleetConfig(world=str(world(tmp, f"rows{urgent_window}", (4.8, 1.8))), seed=0,
                                  physics_hz=20.0, control_hz=10.0)) as svc:
        tm = enable_traffic(svc, cell=1.0, urgent_s=5.0, urgent_cells=None, highway=1.0, lane_cost=1.0,
                            urgent_window=urgent_window)
        for name, (x, y) in {"r0": (-3.5, ROW), "r2": (-3.5, -ROW)}.items():
            svc.spawn_robot(name, Pose2D(x, y, 0.0))
            tm.add(name)
        truth = Truth(svc, tm)
        tm.go("r0", 3.5, ROW)
        tm.go("r2", 3.5, -ROW)
        tm.best_at[0] = svc.world.time - 6.0  # 6 s without progress: urgent at the next plan
        seen = {"r0": 0.0, "r2": 0.0, "arrived": math.inf}
        while svc.world.time < 40.0 and math.isinf(seen["arrived"]):
            svc.advance(0.1)
            for i, name in enumerate(("r0", "r2")):
                seen[name] = max(seen[name], len(tm.sched.queue[i]))
            if tm.a[0] == tm.goal[0] and tm.a[0] == tm.b[0]:
                seen["arrived"] = svc.world.time
        assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
        return seen


@pytest.mark.parametrize("urgent_window", [1, 2, 3])
def test_an_urgent_robot_plans_urgent_window_moves_ahead_and_the_others_window(tmp_path: Path,
                                                                               urgent_window: int) -> None:
    seen = drive_urgent(tmp_path, urgent_window)
    assert seen["r0"] == urgent_window  # planned on while it drives (an empty row: nothing holds it)
    assert seen["r2"] == 1  # not urgent: `window`
    assert seen["arrived"] < 40.0


SHELVES = [(-2.0, 1.5, 2.0, 0.2), (2.0, 1.5, 2.0, 0.2), (-2.0, -1.5, 2.0, 0.2), (2.0, -1.5, 2.0, 0.2)]


def shop(tmp: Path) -> FleetService:
    """A room with four shelves round a crossing (tests/fleet/test_traffic_end_phase.py's too)."""
    return FleetService(FleetConfig(world=str(world(tmp, "shop", (4.8, 3.8), SHELVES)), seed=0, physics_hz=20.0,
                                    control_hz=10.0))


def spawn_shop(svc: FleetService, tm: TrafficManager, rng: np.random.Generator) -> None:
    """Eight robots w0 … w7 at random cells of the layer."""
    for k, c in enumerate(rng.choice(len(tm.grid), 8, replace=False).tolist()):
        svc.spawn_robot(f"w{k}", Pose2D(float(tm.grid.xy[c][0]), float(tm.grid.xy[c][1]), 0.0))
        tm.add(f"w{k}")


def give_goals(tm: TrafficManager, rng: np.random.Generator) -> dict[str, int]:
    """Each robot gets 3 random goals, one after another (one robot per goal cell); the goals each has left."""
    left = dict.fromkeys(tm.names, 3)

    def next_goal(name: str, now: float = 0.0) -> None:
        if left[name]:
            left[name] -= 1
            taken = set(tm.goal.tolist()) | {int(tm.a[tm.names.index(name)])}
            tm.go(name, *tm.grid.xy[int(rng.choice([c for c in range(len(tm.grid)) if c not in taken]))])

    tm.on_reached = next_goal
    for name in left:
        next_goal(name)
    return left


@pytest.mark.parametrize(("urgent_window", "keep_clear"), [(2, False), (3, False), (1, True), (3, True)])
def test_look_ahead_and_clear_crossings_keep_a_lifelong_jam_safe_and_live(tmp_path: Path, urgent_window: int,
                                                                          keep_clear: bool) -> None:
    """Eight robots with lifelong random goals in a shop of shelves, urgent after 1 s without progress (most of
    them are urgent most of the time, each planning ahead), optionally keeping crossings clear (crossings.py; the
    shop's centre is one): no collision, the cells entered in the planned order (the schedule stays acyclic), every
    goal reached. Whether the robots then come to rest is tests/fleet/test_traffic_end_phase.py's question."""
    with shop(tmp_path) as svc:
        tm = enable_traffic(svc, cell=1.0, speed=0.7, stall_s=5.0, urgent_s=1.0, urgent_window=urgent_window,
                            keep_clear=keep_clear, record=True)
        assert len(tm.pibt.box) == (4 if keep_clear else 0)
        rng = np.random.default_rng(5)
        spawn_shop(svc, tm, rng)
        truth = Truth(svc, tm)
        left = give_goals(tm, rng)
        most_queued = 0  # by an urgent robot
        while svc.world.time < 400.0 and tm.stats["reached"] < 24:
            svc.advance(0.5)
            most_queued = max(most_queued, int(tm.sched.queued[np.isfinite(tm.urgent_at)].max(initial=0)))
        assert not any(left.values()) and tm.stats["reached"] == 24, tm.describe()
        assert most_queued >= urgent_window, most_queued
        assert truth.pair > 0.0 and truth.wall > 0.0, (truth.pair, truth.wall)
        planned: dict[int, list[str]] = {}
        for cell, i in tm.sched.planned_entries:
            planned.setdefault(cell, []).append(tm.names[i])
        for cell, entered in truth.entries.items():  # moves still under way have entries planned, not yet made
            assert entered == planned[cell][:len(entered)], (cell, entered, planned[cell])


def test_urgent_window_is_checked(tmp_path: Path) -> None:
    with FleetService(FleetConfig(world=str(world(tmp_path, "rows", (4.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc, pytest.raises(FleetError, match="urgent_window"):
        TrafficManager(svc, urgent_window=0)
