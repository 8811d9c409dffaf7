"""Tool groups; each module's `register(tool)` adds its tools (grouped as the gazebo-mcp README groups them,
see docs/mcp-tools.md)."""

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

TOOL_GROUPS = [sim.register, world.register, robots.register, sensors.register, navigation.register,
               fleet_cmds.register, mapping.register, perception.register, debug.register, records.register,
               missions.register, challenges.register]
