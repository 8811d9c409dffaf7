"""Urgency that expires (manager.py `urgent_cells`): a robot urgent since its best distance was D stops being
urgent once it is `urgent_cells` cells closer than D, not before; with None it stays urgent until its goal."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import TrafficManager, enable_traffic
from fleet.traffic.priority import priorities
from sim import Pose2D
from sim.errors import FleetError
from tests.fleet.test_traffic_async import world


@pytest.mark.parametrize("cells", [None, 2, 3])
def test_urgency_ends_after_urgent_cells_of_progress(tmp_path: Path, cells: int | None) -> None:
    # A room 8 cells wide (x = -3.5 … 3.5), no lane costs: r0 at the west end of the south row, its goal at the
    # east end, 7 cells away.
    with FleetService(FleetConfig(world=str(world(tmp_path, "rows", (4.8, 1.8))), seed=0, physics_hz=20.0,
                                  control_hz=10.0)) as svc:
        tm = enable_traffic(svc, cell=1.0, urgent_s=12.0, urgent_cells=cells, highway=1.0, lane_cost=1.0)
        svc.spawn_robot("r0", Pose2D(-3.5, -0.5, 0.0))
        tm.add("r0")
        goal = tm.go("r0", 3.5, -0.5)
        to = tm.grid.fields.to(goal)
        assert float(to[tm.a[0]]) == 7.0
        tm.best_at[0] = 0.0
        priorities(tm, 12.5)  # 12.5 s without progress: urgent, at best distance 7
        assert math.isfinite(tm.urgent_at[0]) and tm.urgent_d[0] == 7.0
        node_at = {float(to[n]): n for n in range(len(tm.grid)) if abs(tm.grid.xy[n][1] + 0.5) < 0.1}
        for k, d in enumerate([6.0, 5.0, 4.0, 3.0]):  # one cell closer each time
            tm.a[0] = node_at[d]
            tm._progress(0, 13.0 + k)
            expected_urgent = cells is None or 7.0 - d < cells
            assert math.isfinite(tm.urgent_at[0]) == expected_urgent, (cells, d)
            if not expected_urgent:
                break
        if cells is not None:  # urgent again after another urgent_s without progress, from its new best
            t = float(tm.best_at[0]) + 12.0
            priorities(tm, t - 0.1)
            assert math.isinf(tm.urgent_at[0])
            priorities(tm, t)
            assert math.isfinite(tm.urgent_at[0]) and tm.urgent_d[0] == 7.0 - cells
        with pytest.raises(FleetError, match="urgent_cells"):
            TrafficManager(svc, urgent_cells=0)
