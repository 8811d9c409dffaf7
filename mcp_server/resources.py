"""Resources (the fleet state, the map image, each robot's state) and prompts for common workflows."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING

from mcp.server.mcpserver import MCPServer

from mcp_server.shaping import fleet_summary, jsonable

if TYPE_CHECKING:
    from fleet import FleetService


def register_resources(server: MCPServer, service: Callable[[], FleetService]) -> None:
    """`service()` returns the running FleetService (built by the lifespan before any request)."""

    @server.resource("fleetnav://fleet/state", name="fleet_state", mime_type="application/json",
                     description="Fleet summary from the latest snapshot: counts, aggregates, attention list")
    def fleet_state() -> str:
        svc = service()
        snap = svc.snapshot
        return json.dumps({"sim_time": snap.time, **jsonable(fleet_summary(snap, svc.config.battery.low_threshold))})

    @server.resource("fleetnav://health", name="sim_health", mime_type="application/json",
                     description="Whether the sim thread is alive, what it runs, errors, overruns and why it died")
    def sim_health() -> str:
        return json.dumps(service().sim_health())

    @server.resource("fleetnav://map.png", name="map_image", mime_type="image/png",
                     description="The static map with robots, goals and debug markers (north up)")
    async def map_image() -> bytes:
        svc = service()
        png, _ = await svc.acall(lambda: svc.map_image(max_px=800))
        return png

    @server.resource("fleetnav://robots/{name}", name="robot_state", mime_type="application/json",
                     description="One robot's full state from the latest snapshot")
    def robot_state(name: str) -> str:
        snap = service().snapshot
        return json.dumps({"sim_time": snap.time, **snap.robot(name).to_dict("full")})


def register_prompts(server: MCPServer) -> None:
    @server.prompt(name="drive_to_goal", description="Drive one robot to a goal and confirm it arrived")
    def drive_to_goal(robot: str, x: str, y: str) -> str:
        return (f"Drive robot '{robot}' to ({x}, {y}) in fleetnav. 1) get_robot_state for {robot}. 2) plan_path to "
                f"({x}, {y}) with show=true and look at get_occupancy_map; if planning fails pick a free goal nearby. "
                f"3) navigate_to, then wait_for_task with its id until done. 4) report the final pose from "
                f"get_robot_state and the distance to the goal, with sim time.")

    @server.prompt(name="map_with_slam", description="Build a map of the world with SLAM and check its accuracy")
    def map_with_slam(robot: str) -> str:
        return (f"Map the world with robot '{robot}'. start_slam on it; drive a loop through the world with "
                f"follow_waypoints (mode=loop, rounds=1) around the obstacles seen in get_occupancy_map; "
                f"wait_for_task; then slam_status (ATE vs ground truth, loop closures) and get_slam_map; "
                f"save_slam_map to maps/{robot}.yaml. Report ATE RMSE and how many loop closures were accepted.")

    @server.prompt(name="fleet_checkup", description="Inspect the fleet and fix what needs attention")
    def fleet_checkup() -> str:
        return ("Check the fleet: fleet_status (summary), recent_events since the last check, deadlock_report, "
                "monitor_sensor_health. For robots in the attention list: e-stopped → find why in the events "
                "before rearm; low battery → dock_and_charge via assign_tasks or fleet_command return_home; "
                "collisions → get_robot_state and read_sensor lidar. Summarise with sim time.")
