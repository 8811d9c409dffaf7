"""Traffic layer (fleet/traffic): 8 robots swap rooms through a one-lane corridor. A naive planner on the same
grid and executor (each robot takes its best free neighbour, else waits) jams head-on in the corridor; PIBT
completes every swap. Overlaps are checked independently from ground-truth poses after every physics step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import TrafficManager, enable_traffic
from sim import Pose2D
from sim.sdf_primitives import box, enclosure, ground_plane
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription
from tests.fleet.traffic_util import Naive

LEFT = [(-4.5, -1.5), (-4.5, 1.5), (-3.5, -0.5), (-2.5, 1.5)]
STARTS = LEFT + [(-x, y) for x, y in LEFT]  # r0…r3 in the left room, r4…r7 at their mirror cells in the right one


def spawn_swap_fleet(svc: FleetService) -> None:
    """r0…r7 at STARTS, facing +x."""
    for k, (x, y) in enumerate(STARTS):
        svc.spawn_robot(f"r{k}", Pose2D(x, y, 0.0))


def closest_pair_gap(svc: FleetService, radius: float) -> float:
    """The smallest gap between two robots' footprint circles now, from ground-truth poses (< 0: overlap)."""
    f = svc.world.table.f
    xy = np.column_stack([f["x"], f["y"]])
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    d[np.diag_indices(len(xy))] = np.inf
    return float(d.min()) - 2 * radius


def corridor_world(tmp: Path) -> Path:
    """Two 3 × 4-cell rooms joined by a 4-cell corridor one cell wide (y from 0 to 1)."""
    models = [ground_plane(size=14), *enclosure(5.8, 2.8),
              box("block_top", (4.0, 1.8, 1.0), 0.0, 1.9), box("block_bottom", (4.0, 2.8, 1.0), 0.0, -1.4)]
    path = tmp / "corridor.world"
    save_sdf(WorldDescription(name="corridor", models=tuple(models)), str(path))
    return path


def run(tmp: Path, naive: bool, seconds: float) -> tuple[TrafficManager, float, float, float]:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = STARTS
        spawn_swap_fleet(svc)
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0)
        if naive:
            tm.pibt = Naive(tm)  # type: ignore[assignment]
        for k, (x, y) in enumerate(starts):
            tm.add(f"r{k}")
            tm.go(f"r{k}", -x, y)  # to the mirror cell in the other room
        r = tm.radius
        clearance = svc.static_clearance()
        worst = {"pair": np.inf, "wall": np.inf}

        def check() -> None:  # independent of the layer: ground-truth poses, footprint circles
            f = svc.world.table.f
            worst["pair"] = min(worst["pair"], closest_pair_gap(svc, r))
            worst["wall"] = min(worst["wall"], float(clearance.query(np.column_stack([f["x"], f["y"]]))[0].min()) - r)

        svc.step_listeners.append(check)
        t = 0.0
        while t < seconds and (tm.stats["reached"] < len(starts) or tm.active_count()):
            svc.advance(5.0)
            t += 5.0
        return tm, t, worst["pair"], worst["wall"]


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("traffic")


def test_naive_reservation_jams_in_the_corridor(tmp: Path) -> None:
    tm, _, pair, wall = run(tmp, naive=True, seconds=80.0)
    assert tm.stats["reached"] < 8
    assert tm.stats["deadlocks"] > 0 and tm.open_stalls  # reported, never resolved
    assert pair > 0 and wall > 0


def test_pibt_swaps_every_robot_through_the_corridor(tmp: Path) -> None:
    tm, _, pair, wall = run(tmp, naive=False, seconds=400.0)
    assert tm.stats["reached"] >= 8 and tm.active_count() == 0, tm.describe()
    assert not tm.open_stalls
    assert tm.stats["resolved"] == tm.stats["deadlocks"]  # every wait it reported, it also resolved
    assert pair > 0.0, pair  # footprint circles never overlapped
    assert wall > 0.0, wall
    assert tm.stats["pushes"] > 0  # priority inheritance did the work
