"""Simulation tools: status, clock, stepping, reset, profiling, worlds, snapshots."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, ok

pytestmark = pytest.mark.anyio


async def test_status_reports_the_world_and_counts(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    s = await ok(client, "sim_status")
    assert s["world"] == "empty" and s["robots"] == 1 and s["physics_hz"] == 100.0 and s["clock"] == "paused"


async def test_step_advances_exactly_n_physics_steps(client, service: FleetService) -> None:
    s = await ok(client, "step_simulation", {"steps": 37})
    assert s["step_count"] == 37 and s["sim_time"] == pytest.approx(0.37)
    assert service.world.step_count == 37
    await err(client, "step_simulation", {"steps": 0}, "INVALID_ARGUMENT")
    await err(client, "step_simulation", {"steps": "many"}, "INVALID_ARGUMENT")


async def test_pause_unpause_and_speed_set_the_clock(client, service: FleetService) -> None:
    s = await ok(client, "unpause_simulation", {"speed": 4.0})
    assert s["clock"] == "realtime" and service.clock.mode.value == "realtime" and service.clock.speed == 4.0
    await ok(client, "set_simulation_speed", {"speed": 2.5})
    assert service.clock.speed == 2.5 and service.clock.mode.value == "realtime"
    s = await ok(client, "pause_simulation")
    assert s["clock"] == "paused" and service.clock.mode.value == "paused"
    await err(client, "set_simulation_speed", {"speed": -1}, "INVALID_ARGUMENT")
    await err(client, "unpause_simulation", {"speed": 0}, "INVALID_ARGUMENT")


async def test_reset_removes_robots_and_rewinds_time(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.step(20)
    s = await ok(client, "reset_simulation")
    assert s["sim_time"] == 0.0 and service.world.robot_names() == [] and service.world.time == 0.0


async def test_profile_runs_the_steps_and_names_hotspots(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    p = await ok(client, "profile_simulation", {"steps": 20})
    # profiling measures and then puts the world back: a read-only tool never advances time
    assert p["steps"] == 20 and service.world.step_count == 0 and p["step_ms"] > 0 and p["hotspots"]
    await err(client, "profile_simulation", {"steps": 0}, "INVALID_ARGUMENT")


async def test_worlds_list_load_save_and_validate(client, service: FleetService, workspace: Path) -> None:
    names = {w["name"] for w in (await ok(client, "list_worlds"))["worlds"]}
    assert {"empty", "robot_arena", "warehouse"} <= names
    await ok(client, "load_world", {"world": "robot_arena"})
    assert service.world.name == "robot_arena" and "box_crate" in service.world.models.names()
    out = await ok(client, "save_world", {"path": "saved/arena.world"})
    # writes land in the workspace's outputs area; reads look there too
    assert (workspace / "outputs" / "saved" / "arena.world").is_file() and out["message"].startswith("saved")
    v = await ok(client, "validate_world", {"world": "saved/arena.world"})
    assert v["obstacles"] == len(service.world.description.obstacle_models())
    await err(client, "load_world", {"world": "no_such_world"}, "NOT_FOUND")
    await err(client, "save_world", {"path": "/etc/evil.world"}, "PATH_NOT_ALLOWED")
    await err(client, "save_world", {"path": "../outside.world"}, "PATH_NOT_ALLOWED")
    await err(client, "validate_world", {"world": "missing.world"}, "NOT_FOUND")
    await ok(client, "load_world", {"world": "empty"})


async def test_snapshots_restore_the_exact_pose(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    await ok(client, "save_snapshot", {"name": "start"})
    service.drive("r1", 0.5, 0.0, duration=1.0)
    service.advance(1.0)
    assert service.robot("r1").pose.x > 0.3
    listed = (await ok(client, "list_snapshots"))["snapshots"]
    assert [s["name"] for s in listed] == ["start"]
    s = await ok(client, "restore_snapshot", {"name": "start"})
    assert s["sim_time"] == 0.0 and service.robot("r1").pose.x == 0.0
    await err(client, "restore_snapshot", {"name": "nope"}, "NOT_FOUND")
    await err(client, "save_snapshot", {"name": ""}, "INVALID_ARGUMENT")
