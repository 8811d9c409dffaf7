"""FleetService core: concurrency, safety envelope (deadman, e-stop, limits, leases), errors that list names."""

from __future__ import annotations

import asyncio
import math
import threading

import pytest

from fleet import ErrorCode, FleetConfig, FleetError, FleetService, SafetyConfig
from sim import Pose2D


def test_many_concurrent_callers_are_safe():
    """8 threads and 50 asyncio tasks hammer one service mode world; every call lands, state stays consistent."""
    with FleetService(FleetConfig(world="empty", seed=0)) as svc:
        for i in range(8):
            svc.spawn_robot(f"r{i}", Pose2D(3.0 * i, 0.0, 0.0))
        svc.start("fast")
        errors: list[BaseException] = []
        results: list[float] = []

        def worker(i: int) -> None:
            try:
                for k in range(40):
                    res = svc.drive(f"r{i}", 0.3 + 0.01 * k, 0.0, client=f"c{i}")
                    results.append(res.applied_v)
                    snap = svc.snapshot
                    assert len(snap.names) == snap.pose.shape[0] == snap.battery.shape[0]
            except BaseException as exc:  # collected and re-raised below by the test thread
                errors.append(exc)

        threads = [threading.Thread(target=worker, args=(i,)) for i in range(8)]
        for t in threads:
            t.start()

        async def async_reads() -> list[int]:
            return await asyncio.gather(*[svc.acall(lambda: svc.world.step_count) for _ in range(50)])

        counts = asyncio.run(async_reads())
        for t in threads:
            t.join()
        svc.stop()
        assert errors == []
        assert len(results) == 8 * 40
        assert all(c >= 0 for c in counts)
        assert svc.snapshot.time > 0  # the world kept stepping throughout


def test_deadman_stops_a_robot_that_stops_receiving_commands(service: FleetService):
    service.spawn_robot("r", Pose2D())
    service.drive("r", 0.5, 0.0)
    service.advance(0.4)
    assert service.robot("r").v > 0.3
    service.advance(1.5)  # deadman 0.5 s: the command lapsed and the robot braked to a stop
    assert service.robot("r").v == pytest.approx(0.0, abs=1e-9)
    x = service.robot("r").pose.x
    service.advance(1.0)
    assert service.robot("r").pose.x == pytest.approx(x, abs=1e-9)


def test_estop_stays_latched_until_rearmed(service: FleetService):
    service.spawn_robot("r", Pose2D())
    service.estop("r", "test")
    with pytest.raises(FleetError) as e:
        service.drive("r", 0.5, 0.0)
    assert e.value.code is ErrorCode.ESTOPPED
    service.advance(2.0)
    assert service.robot("r").estopped
    assert service.robot("r").pose.x == 0.0
    assert service.rearm("r")
    service.drive("r", 0.5, 0.0, duration=1.0)
    service.advance(1.0)
    assert service.robot("r").pose.x > 0.1


def test_fleet_estop_stops_autonomy_too():
    with FleetService(FleetConfig(world="empty")) as svc:
        svc.spawn_robot("r", Pose2D())
        task = svc.navigate("r", Pose2D(5.0, 0.0, 0.0))
        svc.advance(2.0)
        svc.estop(None, "fleet stop")
        x = svc.robot("r").pose.x
        svc.advance(3.0)
        assert svc.robot("r").pose.x == pytest.approx(x, abs=1e-9)  # an e-stop halts at once
        svc.rearm(None)
        svc.advance(15.0)
        assert svc.task_status(task["id"])["state"] == "succeeded"


def test_limits_clamp_and_report_or_reject_in_strict_mode():
    with FleetService(FleetConfig(world="empty")) as svc:
        svc.spawn_robot("r", Pose2D())
        res = svc.drive("r", 3.0, 0.0)
        assert res.clamped and res.applied_v == 1.0 and "exceeds" in res.reason
    strict = FleetConfig(world="empty", safety=SafetyConfig(strict=True))
    with FleetService(strict) as svc:
        svc.spawn_robot("r", Pose2D())
        with pytest.raises(FleetError) as e:
            svc.drive("r", 3.0, 0.0)
        assert e.value.code is ErrorCode.LIMIT_EXCEEDED
        assert svc.drive("r", 0.5, 0.0).applied_v == 0.5


def test_one_controlling_client_per_robot(service: FleetService):
    service.spawn_robot("r", Pose2D())
    service.drive("r", 0.2, 0.0, client="alice")
    with pytest.raises(FleetError) as e:
        service.drive("r", 0.2, 0.0, client="bob")
    assert e.value.code is ErrorCode.LEASE_HELD and "alice" in e.value.message
    assert service.release_lease("alice", "r")
    service.drive("r", 0.2, 0.0, client="bob")


def test_unknown_robot_error_lists_known_robots(service: FleetService):
    service.spawn_robot("alpha", Pose2D())
    with pytest.raises(FleetError) as e:
        service.drive("omega", 0.1, 0.0)
    assert e.value.code is ErrorCode.UNKNOWN_ROBOT and "alpha" in e.value.hint
    with pytest.raises(FleetError) as e2:
        service.navigate("omega", Pose2D(1, 1, 0))
    assert "alpha" in e2.value.hint


def test_nan_commands_rejected_and_world_keeps_running(service: FleetService):
    service.spawn_robot("r", Pose2D())
    with pytest.raises(FleetError):
        service.drive("r", math.nan, 0.0)
    t = service.step(10)
    assert t == pytest.approx(0.1)


def test_task_into_a_wall_fails_with_a_reason():
    with FleetService(FleetConfig(world="robot_arena")) as svc:
        svc.spawn_robot("r", Pose2D(-5, -5, 0))
        t = svc.navigate("r", Pose2D(6.1, 0.0, 0.0))  # inside the east wall
        svc.advance(3.0)
        st = svc.task_status(t["id"])
        assert st["state"] == "failed" and "planning failed" in st["reason"].lower()
        assert "in collision" in st["reason"]
        kinds = [e.kind for e in svc.events.since(0)]
        assert "task_failed" in kinds
