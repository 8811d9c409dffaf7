"""Tool groups (toolsets); each module's `register(tool)` adds its tools (grouped as the gazebo-mcp README groups
them, see docs/mcp-tools.md). `fleetnav serve --toolsets core,slam` picks what a server exposes: `core` is a
lean cross-section (≤ 30 tools) an assistant needs to drive a fleet, each other name adds a whole group, `all`
is everything."""

from mcp_server.tools import (
    challenges,
    debug,
    fleet_cmds,
    mapping,
    missions,
    navigation,
    perception,
    records,
    robots,
    sensors,
    sim,
    world,
)

# toolset name → its register function (order = tools/list order)
TOOLSETS = {"sim": sim.register, "world": world.register, "robots": robots.register, "sensors": sensors.register,
            "nav": navigation.register, "fleet": fleet_cmds.register, "slam": mapping.register,
            "perception": perception.register, "debug": debug.register, "records": records.register,
            "missions": missions.register, "challenges": challenges.register}
TOOL_GROUPS = list(TOOLSETS.values())

# The default toolset: observe, step, drive, navigate, allocate, recover. Room is left under the 30-tool cap.
CORE = frozenset({
    "sim_status", "sim_health", "step_simulation", "unpause_simulation", "reset_simulation", "load_world",
    "list_robots", "get_robot_state", "spawn_robot", "drive_robot", "stop_robot", "emergency_stop", "rearm",
    "read_sensor", "navigate_to", "follow_waypoints", "plan_path", "task_status", "wait_for_task", "cancel_task",
    "get_occupancy_map", "fleet_status", "assign_tasks", "run_mission"})
DEFAULT_TOOLSETS = ("core",)


def parse_toolsets(spec: str | tuple[str, ...] | list[str] | None) -> frozenset[str]:
    """'core,slam' → {'core', 'slam'}; unknown names are an error listing the valid ones."""
    from sim.errors import ErrorCode, unknown_name

    names = spec.split(",") if isinstance(spec, str) else list(spec or DEFAULT_TOOLSETS)
    out = frozenset(n.strip() for n in names if n.strip())
    valid = ["all", "core", *TOOLSETS]
    for n in out:
        if n not in valid:
            raise unknown_name("toolset", n, valid, ErrorCode.INVALID_ARGUMENT)
    return out
