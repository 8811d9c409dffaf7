"""A manual cmd_vel reaches the robot at the next physics step after it arrives, not the next control tick
(issue 17): checked against the closed form of one step of the acceleration-limited unicycle."""

from __future__ import annotations

import pytest

from fleet import FleetConfig, FleetService
from sim import Pose2D

V = 0.5


def _one_step_x(svc: FleetService, x0: float) -> float:
    """x after one 1/physics_hz step from rest at heading 0: the setpoint ramps by max_a·dt, then moves."""
    f, i = svc.world.table.f, svc.world.table.index("r0")
    dt = svc.world.dt
    return x0 + min(V, float(f["max_a"][i]) * dt) * dt


@pytest.mark.parametrize("threaded", [False, True])
def test_drive_is_applied_by_the_next_physics_step(threaded: bool) -> None:
    with FleetService(FleetConfig(world="empty", seed=0, physics_hz=100.0, control_hz=10.0)) as svc:
        svc.spawn_robot("r0", Pose2D(0.0, 0.0, 0.0))
        if threaded:
            svc.start("paused")  # the sim thread drains commands; only explicit steps advance time
        svc.step(3)  # mid control period: the next control tick is 7 physics steps away
        assert svc.call(lambda: svc.world.step_count % svc._steps_per_control) == 3
        x0 = svc.snapshot.pose[0, 0] if not threaded else svc.call(lambda: float(svc.world.table.f["x"][0]))
        res = svc.drive("r0", V, 0.0)
        assert res.applied_v == V
        svc.step(1)
        x1, cmd = svc.call(lambda: (float(svc.world.table.f["x"][0]), float(svc.world.table.f["cmd_v"][0])))
        assert cmd == V
        assert x1 == pytest.approx(_one_step_x(svc, x0), abs=1e-12)
        assert x1 > x0
