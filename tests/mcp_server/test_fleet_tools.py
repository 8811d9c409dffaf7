"""Fleet tools: formations (spacing by construction), fleet status and its size for 100 robots, fleet commands,
queue and allocation (dry run submits nothing), swarm behaviours, avoidance, deadlocks, network markers."""

from __future__ import annotations

import itertools
import json
import math

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, ok

pytestmark = pytest.mark.anyio


async def spawn_square(client) -> list[str]:
    out = await ok(client, "spawn_fleet", {"count": 4, "formation": "grid", "centre": {"x": 0, "y": 0},
                                           "spacing": 1.5})
    return out["result"]["robots"]


async def test_spawn_fleet_places_a_grid_at_the_spacing(client, service: FleetService) -> None:
    names = await spawn_square(client)
    assert names == ["robot1", "robot2", "robot3", "robot4"] and service.world.robot_names() == names
    xy = [service.robot(n).pose for n in names]
    dists = sorted(a.distance_to(b) for a, b in itertools.combinations(xy, 2))
    assert dists[:4] == pytest.approx([1.5] * 4) and dists[4:] == pytest.approx([1.5 * math.sqrt(2)] * 2)
    await err(client, "spawn_fleet", {"count": 2, "spacing": 0.1}, "INVALID_ARGUMENT")  # footprints overlap
    await err(client, "spawn_fleet", {"count": 2, "formation": "blob"}, "INVALID_ARGUMENT")


async def test_fleet_status_summary_for_100_robots_stays_small(client, service: FleetService) -> None:
    await ok(client, "spawn_fleet", {"count": 100, "formation": "grid", "centre": {"x": 0, "y": 0}, "spacing": 0.8})
    r = await client.call_tool("fleet_status", {})
    text = r.content[0].text
    assert len(text) / 4 < 500, f"summary of 100 robots is ~{len(text) / 4:.0f} tokens"
    s = json.loads(text)["summary"]
    assert s["robots"] == 100 and s["names"] == "robot1..robot100"
    r = await client.call_tool("list_robots", {"response_format": "summary"})
    assert len(r.content[0].text) / 4 < 500
    normal = await ok(client, "fleet_status", {"response_format": "normal"})
    assert len(normal["robots"]) == 100 and normal["deadlocks"]["detected"] == 0


async def test_fleet_move_keeps_the_formation_and_stop_releases(client, service: FleetService) -> None:
    names = await spawn_square(client)
    before = {n: service.robot(n).pose for n in names}
    m = await ok(client, "fleet_command", {"command": "move", "target": {"x": 1.0, "y": 1.0}})
    goals = m["result"]["goals"]
    for n in names:  # the square moves rigidly by (+1, +1)
        assert (goals[n]["x"], goals[n]["y"]) == pytest.approx((before[n].x + 1.0, before[n].y + 1.0), abs=1e-6)
    assert set(m["result"]["tasks"]) == set(names)
    service.advance(1.0)
    await ok(client, "fleet_command", {"command": "stop"})
    assert all(service.task_status(t)["state"] == "canceled" for t in m["result"]["tasks"].values())
    home = await ok(client, "fleet_command", {"command": "return_home", "robots": ["robot1"]})
    assert home["result"]["goals"]["robot1"]["x"] == pytest.approx(before["robot1"].x)
    await err(client, "fleet_command", {"command": "move"}, "INVALID_ARGUMENT")
    await err(client, "fleet_command", {"command": "dance"}, "INVALID_ARGUMENT")
    await err(client, "fleet_command", {"command": "stop", "robots": ["ghost"]}, "UNKNOWN_ROBOT")


async def test_assign_tasks_dry_run_submits_nothing_then_assigns(client, service: FleetService) -> None:
    await spawn_square(client)
    q = await ok(client, "queue_task", {"spec": {"type": "go_to", "params": {"goal": {"x": 3, "y": 3}}}})
    assert q["result"]["type"] == "go_to"
    dry = await ok(client, "assign_tasks", {"dry_run": True, "cost": "euclidean"})
    a = dry["result"]["assignments"]
    assert dry["result"]["dry_run"] and len(a) == 1 and service.tasks.tasks == {} and a[0]["task_ids"] == []
    nearest = min(service.world.robot_names(), key=lambda n: service.robot(n).pose.distance_to(Pose2D(3, 3)))
    assert a[0]["robot"] == nearest
    real = await ok(client, "assign_tasks", {"cost": "euclidean"})
    (tid,) = real["result"]["assignments"][0]["task_ids"]
    assert service.task_status(tid)["robot"] == nearest
    await err(client, "assign_tasks", {"tasks": [{"type": "teleport"}]}, "INVALID_ARGUMENT")
    await err(client, "assign_tasks", {"method": "lottery"}, "INVALID_ARGUMENT")
    await err(client, "queue_task", {"spec": {"type": "return_home"}})


async def test_docks_listed_from_the_world(client, service: FleetService) -> None:
    assert (await ok(client, "list_docks"))["items"] == []  # the empty world has no dock_* models


async def test_swarm_behaviour_runs_and_reports_its_metric(client, service: FleetService) -> None:
    await spawn_square(client)
    b = await ok(client, "start_swarm_behaviour", {"behaviour": "rendezvous"})
    bid = b["result"]["id"]
    service.advance(3.0)
    st = (await ok(client, "swarm_status", {"behaviour_id": bid}))["items"][0]
    assert st["state"] == "running" and st["metrics"] and st["metrics"] != st["initial_metrics"]
    assert len((await ok(client, "swarm_status"))["items"]) == 1
    stopped = await ok(client, "stop_swarm_behaviour", {"behaviour_id": bid})
    assert stopped["result"]["state"] != "running"
    await err(client, "start_swarm_behaviour", {"behaviour": "dance"}, "INVALID_ARGUMENT")
    await err(client, "stop_swarm_behaviour", {"behaviour_id": "b999"})


async def test_avoidance_settings_switch_and_tune(client, service: FleetService) -> None:
    g = await ok(client, "get_collision_avoidance")
    assert g["result"]["type"] == "orca"
    s = await ok(client, "set_collision_avoidance", {"settings": {"time_horizon": 3.5}})
    assert s["result"]["time_horizon"] == 3.5 and service.avoidance_settings()["time_horizon"] == 3.5
    off = await ok(client, "set_collision_avoidance", {"plugin": "none"})
    assert off["result"]["type"] == "none" and service.avoidance_settings()["type"] == "none"
    await err(client, "set_collision_avoidance", {"plugin": "orca", "settings": {"warp": 9.0}})


async def test_deadlock_report_and_policy(client, service: FleetService) -> None:
    r = await ok(client, "deadlock_report")
    assert r["result"]["detected"] == 0 and r["result"]["config"]["policy"] == "priority"
    c = await ok(client, "configure_deadlocks", {"policy": "replan", "settings": {"wait_s": 5.0}})
    assert c["result"]["policy"] == "replan" and service.deadlocks.config.wait_s == 5.0
    await err(client, "configure_deadlocks", {"policy": "panic"}, "INVALID_ARGUMENT")
    await err(client, "configure_deadlocks", {"settings": {"wait_s": -1.0}})


async def test_network_view_draws_the_comms_graph(client, service: FleetService) -> None:
    await spawn_square(client)
    net = await ok(client, "visualize_robot_network", {"view": "comms", "comm_range": 2.0})
    assert net["result"]["markers"] == 4  # the square's sides (1.5 m) are in range, its diagonals (2.12 m) not
    assert len(service.list_markers("network")) == 4
    zones = await ok(client, "visualize_robot_network", {"view": "collision_zones"})
    assert zones["result"]["markers"] == 0 and service.list_markers("network") == []
    await err(client, "visualize_robot_network", {"view": "comms", "comm_range": 0}, "INVALID_ARGUMENT")
    await err(client, "visualize_robot_network", {"robots": ["ghost"]}, "UNKNOWN_ROBOT")
