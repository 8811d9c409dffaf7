"""Robot tools: list/inspect, spawn/remove, drive through the safety envelope, e-stop, leases, battery."""

from __future__ import annotations

import json

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, ok

pytestmark = pytest.mark.anyio


async def test_spawn_then_list_and_get_state(client, service: FleetService) -> None:
    r = await ok(client, "spawn_robot", {"name": "r1", "x": 1.0, "y": -2.0, "yaw": 0.5})
    assert r["robot"]["x"] == 1.0 and service.robot("r1").pose == Pose2D(1.0, -2.0, 0.5)
    s = await ok(client, "list_robots")
    assert s["total"] == 1 and s["summary"]["robots"] == 1 and s["summary"]["names"] == "r1" and s["robots"] is None
    n = await ok(client, "list_robots", {"response_format": "normal"})
    assert n["robots"][0]["name"] == "r1" and "battery" in n["robots"][0] and "lease" not in n["robots"][0]
    f = await ok(client, "list_robots", {"response_format": "full"})
    assert f["robots"][0]["fidelity"] == "kinematic"
    g = await ok(client, "get_robot_state", {"robot": "r1"})
    assert g["robot"]["yaw"] == 0.5 and g["tasks"] == []
    await err(client, "spawn_robot", {"name": "r1"}, "INVALID_ARGUMENT")  # taken
    await err(client, "spawn_robot", {"name": "bad name!"}, "INVALID_ARGUMENT")
    await err(client, "get_robot_state", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_list_robots_pages_normal_rows(client, service: FleetService) -> None:
    for i in range(5):
        service.spawn_robot(f"r{i}", Pose2D(i * 1.5 - 3, 0, 0))
    page = await ok(client, "list_robots", {"response_format": "normal", "limit": 2, "offset": 2})
    assert [r["name"] for r in page["robots"]] == ["r2", "r3"] and page["next_offset"] == 4 and page["total"] == 5
    assert (await ok(client, "list_robots", {"response_format": "summary"}))["summary"]["names"] == "r0..r4"
    await err(client, "list_robots", {"limit": 0}, "INVALID_ARGUMENT")


async def test_drive_straight_matches_the_trapezoidal_profile(client, service: FleetService) -> None:
    """v = 0.5 m/s for 2 s from rest with a 1.5 m/s² limit: d = v·T − v²/(2a) = 1 − 0.0833 = 0.9167 m."""
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    d = await ok(client, "drive_robot", {"robot": "r1", "v": 0.5, "w": 0.0, "duration": 2.0})
    assert d["applied"] == {"v": 0.5, "w": 0.0} and not d["clamped"]
    assert d["achieved"]["distance_m"] == pytest.approx(1.0 - 0.5**2 / (2 * 1.5), abs=0.01)
    assert d["achieved"]["duration_s"] == pytest.approx(2.0, abs=0.011)
    assert service.robot("r1").pose.x == pytest.approx(d["achieved"]["final_pose"]["x"], abs=1e-3)


async def test_drive_clamps_to_the_limits_and_says_so(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    d = await ok(client, "drive_robot", {"robot": "r1", "v": 5.0, "w": -9.0, "duration": 0.5, "wait": False})
    assert d["clamped"] and d["applied"] == {"v": 1.0, "w": -2.0} and d["reason"] and d["achieved"] is None
    await err(client, "drive_robot", {"robot": "ghost", "v": 0.1, "w": 0}, "UNKNOWN_ROBOT")
    await err(client, "drive_robot", {"robot": "r1", "v": 0.1, "w": 0, "duration": 0}, "INVALID_ARGUMENT")
    await err(client, "drive_robot", {"robot": "r1", "v": "fast", "w": 0}, "INVALID_ARGUMENT")


async def test_stop_takes_over_from_a_task(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    t = service.navigate("r1", Pose2D(3, 0, 0))
    service.advance(1.0)
    s = await ok(client, "stop_robot", {"robot": "r1"})
    assert s["applied"] == {"v": 0.0, "w": 0.0}
    assert service.task_status(t["id"])["state"] == "canceled"
    await err(client, "stop_robot", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_estop_latches_until_rearm(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.spawn_robot("r2", Pose2D(2, 0, 0))
    e = await ok(client, "emergency_stop", {"robot": "r1"})
    assert e["robots"] == ["r1"] and service.snapshot.robot("r1").estopped
    text = await err(client, "drive_robot", {"robot": "r1", "v": 0.3, "w": 0}, "ESTOPPED")
    assert "re-arm" in text
    await ok(client, "rearm", {"robot": "r1"})
    assert not service.snapshot.robot("r1").estopped
    fleet = await ok(client, "emergency_stop", {})
    assert sorted(fleet["robots"]) == ["r1", "r2"] and service.snapshot.fleet_estopped
    await ok(client, "rearm", {})
    assert not service.snapshot.fleet_estopped
    await err(client, "emergency_stop", {"robot": "ghost"}, "UNKNOWN_ROBOT")
    await err(client, "rearm", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_lease_keeps_other_clients_out(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    await ok(client, "acquire_lease", {"robot": "r1"})
    assert (service.safety.holder("r1") or "").startswith("mcp")  # mcp[/session or client name]
    with pytest.raises(Exception, match="LEASE_HELD"):
        service.drive("r1", 0.2, 0.0, client="someone-else")
    r = await ok(client, "release_lease", {"robot": "r1"})
    assert "released" in r["message"] and service.safety.holder("r1") is None
    service.acquire_lease("other", "r1")
    await err(client, "drive_robot", {"robot": "r1", "v": 0.1, "w": 0, "wait": False}, "LEASE_HELD")
    await err(client, "acquire_lease", {"robot": "r1"}, "LEASE_HELD")
    await err(client, "acquire_lease", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_set_battery_and_remove_robot(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    b = await ok(client, "set_battery", {"robot": "r1", "soc": 0.15})
    assert b["robot"]["battery"] == 0.15 and float(service.battery.soc[0]) == 0.15
    summary = (await ok(client, "list_robots"))["summary"]
    assert summary["attention"] == [{"name": "r1", "issues": ["low_battery"]}]
    await err(client, "set_battery", {"robot": "r1", "soc": 1.5}, "INVALID_ARGUMENT")
    await ok(client, "remove_robot", {"robot": "r1"})
    assert service.world.robot_names() == []
    await err(client, "remove_robot", {"robot": "r1"}, "UNKNOWN_ROBOT")


async def test_text_content_is_compact_json(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    r = await client.call_tool("list_robots", {"response_format": "normal"})
    text = r.content[0].text
    assert "\n" not in text and json.loads(text) == r.structured_content
