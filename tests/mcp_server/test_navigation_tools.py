"""Navigation tools: plans against straight-line distances, navigation to a goal with progress notifications,
waypoints, coverage, task lifecycle, the map image, keep-out zones."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, image, ok

pytestmark = pytest.mark.anyio

WALL = """<sdf version="1.9"><model name="wall"><static>true</static><link name="l">
<collision name="c"><geometry><box><size>0.2 3 1.0</size></box></geometry></collision>
<visual name="v"><geometry><box><size>0.2 3 1.0</size></box></geometry></visual></link></model></sdf>"""

# The rasterised map spans the obstacles' bounds: two corner posts give the empty world a ±6 m map once a
# wall is spawned in it (without any obstacle the map is the default ±5 m).
POST = """<sdf version="1.9"><model name="{name}"><static>true</static><pose>{x} {y} 0.5 0 0 0</pose><link name="l">
<collision name="c"><geometry><cylinder><radius>0.05</radius><length>1</length></cylinder></geometry></collision>
</link></model></sdf>"""


async def frame_world(client) -> None:
    for name, x, y in (("post_a", -6, -6), ("post_b", 6, 6)):
        await ok(client, "spawn_model", {"xml": POST.format(name=name, x=x, y=y)})


async def test_plan_is_straight_in_free_space_and_detours_round_a_wall(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    free = await ok(client, "plan_path", {"robot": "r1", "x": 4.0, "y": 0.0})
    assert free["length_m"] == pytest.approx(4.0, abs=0.05)
    assert free["path"]["polyline"][0] == [0.0, 0.0] and free["path"]["polyline"][-1] == [4.0, 0.0]
    await frame_world(client)
    await ok(client, "spawn_model", {"xml": WALL, "pose": {"x": 2.0, "y": 0.0, "z": 0.5}})
    around = await ok(client, "plan_path", {"robot": "r1", "x": 4.0, "y": 0.0, "show": True,
                                            "response_format": "summary"})
    # Round the wall's end (y = ±1.5) with the robot's clearance: at least the two straight legs via (2, 1.5).
    assert around["length_m"] > 2 * math.hypot(2.0, 1.5) and around["marker"] is not None
    assert "polyline" not in around["path"] and len(service.markers.markers) == 1
    await err(client, "plan_path", {"robot": "r1", "x": 2.0, "y": 0.0}, "PLANNING_FAILED")  # inside the wall
    await err(client, "plan_path", {"robot": "r1", "x": 4.0, "y": 0.0, "planner": "dijkstra9"})
    await err(client, "plan_path", {"robot": "ghost", "x": 1.0, "y": 0.0}, "UNKNOWN_ROBOT")


async def test_navigate_returns_an_id_and_wait_reports_progress_until_arrival(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    t = await ok(client, "navigate_to", {"robot": "r1", "x": 3.0, "y": 1.0})
    assert t["task"]["state"] == "queued" and t["sim_time"] == 0.0  # returned at once, nothing stepped
    seen: list[tuple[float, float | None, str | None]] = []

    async def on_progress(progress: float, total: float | None, message: str | None) -> None:
        seen.append((progress, total, message))

    w = await ok(client, "wait_for_task", {"task_id": t["task"]["id"], "timeout_s": 60}, progress_callback=on_progress)
    assert w["done"] and w["task"]["state"] == "succeeded"
    assert service.robot("r1").pose.distance_to(Pose2D(3.0, 1.0)) < 0.25
    assert len(seen) >= 2 and all(b[0] >= a[0] for a, b in itertools.pairwise(seen))
    s = await ok(client, "task_status", {"task_id": t["task"]["id"], "response_format": "full"})
    assert s["task"]["params"]["goal"] == {"x": 3.0, "y": 1.0, "yaw": 0.0}
    await err(client, "navigate_to", {"robot": "r1", "x": 1.0, "y": 0.0, "controller": "teleport"})
    await err(client, "task_status", {"task_id": "t999"}, "NOT_FOUND")
    await err(client, "wait_for_task", {"task_id": "t999"}, "NOT_FOUND")


async def test_wait_gives_up_at_its_timeout_and_cancel_stops_the_task(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    t = (await ok(client, "navigate_to", {"robot": "r1", "x": 4.0, "y": 0.0}))["task"]["id"]
    w = await ok(client, "wait_for_task", {"task_id": t, "timeout_s": 1.0})
    assert not w["done"] and w["task"]["state"] == "active" and w["sim_time"] == pytest.approx(1.0, abs=0.11)
    listed = (await ok(client, "list_tasks", {"robot": "r1"}))["tasks"]
    assert [x["id"] for x in listed] == [t]
    c = await ok(client, "cancel_task", {"task_id": t})
    assert c["task"]["state"] == "canceled" and service.task_status(t)["state"] == "canceled"
    assert (await ok(client, "list_tasks", {"robot": "r1"}))["tasks"] == []
    assert len((await ok(client, "list_tasks", {"include_done": True}))["tasks"]) == 1
    await err(client, "cancel_task", {"task_id": "t999"}, "NOT_FOUND")
    await err(client, "list_tasks", {"robot": "ghost", "limit": 0}, "INVALID_ARGUMENT")


async def test_follow_waypoints_visits_them_in_order(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    t = await ok(client, "follow_waypoints", {"robot": "r1", "waypoints": [{"x": 1.5, "y": 0.0},
                                                                           {"x": 1.5, "y": 1.5, "dwell_s": 0.5}]})
    w = await ok(client, "wait_for_task", {"task_id": t["task"]["id"], "timeout_s": 60})
    assert w["task"]["state"] == "succeeded"
    assert service.robot("r1").pose.distance_to(Pose2D(1.5, 1.5)) < 0.25
    reached = [e for e in service.events.since(0, ["waypoint_reached"])]
    assert len(reached) == 2
    await err(client, "follow_waypoints", {"robot": "r1", "waypoints": []}, "INVALID_ARGUMENT")
    await err(client, "follow_waypoints", {"robot": "r1", "waypoints": [{"x": 1, "y": 1}], "mode": "zigzag"},
              "INVALID_ARGUMENT")


async def test_cover_area_measures_the_coverage_it_drove(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    square = [[0.5, -0.75], [2.0, -0.75], [2.0, 0.75], [0.5, 0.75]]
    t = await ok(client, "cover_area", {"robot": "r1", "polygon": square, "tool_width": 0.5})
    w = await ok(client, "wait_for_task", {"task_id": t["task"]["id"], "timeout_s": 120})
    assert w["task"]["state"] == "succeeded", w["task"]
    assert w["task"]["progress"]["coverage_pct"] > 80.0
    await err(client, "cover_area", {"robot": "r1", "polygon": [[0, 0], [1, 0]]}, "INVALID_ARGUMENT")
    await err(client, "cover_area", {"robot": "r1", "polygon": square, "tool_width": 0}, "INVALID_ARGUMENT")


async def test_occupancy_map_image_shows_walls_where_they_are(client, service: FleetService) -> None:
    await frame_world(client)
    await ok(client, "spawn_model", {"xml": WALL, "pose": {"x": 2.0, "y": 0.0, "z": 0.5}})
    service.spawn_robot("r1", Pose2D(-2, 0, 0))
    img, meta = await image(client, "get_occupancy_map", {"show_robots": False})
    assert img.shape[:2] == (meta["height"], meta["width"]) and meta["layer"] == "static"
    mpp, (xmin, _), ymax = meta["metres_per_pixel"], meta["origin"], meta["bounds"][3]

    def px(x: float, y: float) -> np.ndarray:
        return img[int((ymax - y) / mpp), int((x - xmin) / mpp)]

    assert tuple(px(2.0, 0.0)[:3]) == (0, 0, 0)  # the wall is black
    assert tuple(px(-1.0, 1.0)[:3]) == (255, 255, 255)  # free space is white
    cm, cmeta = await image(client, "get_occupancy_map", {"robot": "r1", "max_px": 200})
    assert max(cm.shape[:2]) <= 200 and cmeta["layer"] == "costmap of r1"
    await err(client, "get_occupancy_map", {"robot": "ghost"}, "UNKNOWN_ROBOT")
    await err(client, "get_occupancy_map", {"max_px": 10}, "INVALID_ARGUMENT")


async def test_keepout_zones_change_plans_and_clear(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    zone = [[1.5, -1.0], [2.5, -1.0], [2.5, 1.0], [1.5, 1.0]]
    k = await ok(client, "add_keepout_zone", {"polygon": zone})
    assert k["zones"] == 1
    plan = await ok(client, "plan_path", {"robot": "r1", "x": 4.0, "y": 0.0})
    assert plan["length_m"] > 2 * math.hypot(2.0, 1.0)  # around the zone, not through it
    listed = await ok(client, "list_keepout_zones")
    assert listed["polygons"] == [zone]
    await ok(client, "clear_keepout_zones")
    assert service.list_keepouts() == []
    assert (await ok(client, "plan_path", {"robot": "r1", "x": 4.0, "y": 0.0}))["length_m"] == pytest.approx(4.0,
                                                                                                             abs=0.05)
    await err(client, "add_keepout_zone", {"polygon": [[0, 0], [1, 1]]}, "INVALID_ARGUMENT")


async def test_navigation_options_list_the_plugins(client) -> None:
    o = await ok(client, "navigation_options")
    assert "theta_star" in o["planners"] and "mpc_osqp" in o["controllers"] and "go_to" in o["task_types"]
    assert o["defaults"]["goal_tolerance"] > 0
