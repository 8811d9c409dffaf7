"""Fleet tools: spawn in formation, fleet status, fleet commands, task queue and allocation (dry run), docks,
swarm behaviours with their metrics, multi-robot avoidance, deadlocks, the robot network drawn as markers."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from mcp.server.mcpserver import Context
from pydantic import BaseModel, Field, WithJsonSchema

from fleet.avoidance import avoidance_configs
from fleet.deadlock import DeadlockConfig
from fleet.swarm import behaviour_configs
from fleet.task_params import allocatable_union
from mcp_server.app import app_of, client_of, run
from mcp_server.plugin_params import checked, settings_schema
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat, fleet_summary
from sim import Pose2D

Formation = Literal["line", "column", "grid", "circle", "wedge", "random"]
# Per-type settings: the schema lists each registered type's fields; the tool validates against the one named.
BehaviourParams = Annotated[dict[str, Any] | None, WithJsonSchema(settings_schema(behaviour_configs(), "behaviour"))]
AvoidanceSettings = Annotated[dict[str, Any] | None, WithJsonSchema(settings_schema(avoidance_configs(),
                                                                                    "avoidance"))]


class PoseXY(BaseModel):
    x: float
    y: float
    yaw: float = 0.0

    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


# A task spec per allocatable type ({type, params, priority, ...}), told apart by `type`: the schema lists each
# type's params (fleet/task_params.py), and the service validates the same models for every door.
if TYPE_CHECKING:
    TaskSpec = BaseModel
else:
    TaskSpec = allocatable_union()


class Result(Answer):
    result: dict[str, Any]


class Items(Answer):
    items: list[dict[str, Any]]


class FleetStatus(Answer):
    summary: dict[str, Any]
    robots: list[dict[str, Any]] | None = None
    behaviours: list[dict[str, Any]] | None = None
    deadlocks: dict[str, Any] | None = None


def _assignment_view(a: dict[str, Any], fmt: ResponseFormat) -> dict[str, Any]:
    if fmt == "full":
        return a
    d = {k: v for k, v in a.items() if k != "path"}
    d["path_points"] = len(a.get("path") or [])
    return d


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=False, title="Spawn a fleet in formation")
    async def spawn_fleet(ctx: Context, count: int = Field(ge=1, le=1000), formation: Formation = "grid",
                          centre: PoseXY | None = Field(None, description="omitted: the world's centre"),
                          spacing: float = Field(1.5, gt=0, le=50), prefix: str = "robot",
                          radius: float | None = Field(None, gt=0, description="random: sampling radius"),
                          fidelity: Literal["kinematic", "dynamic"] | None = None) -> Result:
        """Spawn `count` robots in a formation, every slot checked free of obstacles and robots."""
        svc = app_of(ctx).service
        out = await run(ctx, svc.spawn_fleet, count, formation, centre.pose() if centre else None, spacing, prefix,
                        radius=radius, fidelity=fidelity)
        if count > 20:
            out["poses"] = f"{len(out['poses'])} poses (list_robots for them)"
        return Result(sim_time=svc.sim_time, result=out)

    @tool(read_only=True, title="Fleet status")
    async def fleet_status(ctx: Context, response_format: ResponseFormat = "summary") -> FleetStatus:
        """The whole fleet: summary (aggregates, attention list), normal (+ per-robot rows, behaviours,
        deadlocks), full (+ every field)."""
        svc = app_of(ctx).service
        snap = svc.snapshot
        out = FleetStatus(sim_time=snap.time, summary=fleet_summary(snap, svc.config.battery.low_threshold))
        if response_format != "summary":
            out.robots = [v.to_dict(response_format) for v in snap.robots()]
            out.behaviours = await run(ctx, svc.behaviour_status)
            rep = await run(ctx, svc.deadlock_report)
            out.deadlocks = rep if response_format == "full" else {k: rep[k] for k in ("detected", "resolved",
                                                                                       "unresolved", "active")}
        return out

    @tool(read_only=False, title="Fleet command")
    async def fleet_command(ctx: Context, command: Literal["move", "stop", "formation", "sync", "return_home"],
                            robots: list[str] | None = Field(None, description="omitted: every robot"),
                            target: PoseXY | None = Field(None, description="move/formation: the group's centre"),
                            formation: Formation | None = None, spacing: float | None = Field(None, gt=0, le=50),
                            queue: bool = Field(False, description="append to the robots' work instead of "
                                                "replacing it"),
                            timeout_s: float | None = Field(None, gt=0, description="sync: give up after")) -> Result:
        """move (formation kept), stop, formation (change shape), sync (barrier: all wait for the slowest),
        return_home. Returns each robot's task id at once."""
        app = app_of(ctx)
        out = await run(ctx, app.service.fleet_command, command, robots, target=target.pose() if target else None,
                        formation=formation, spacing=spacing, queue=queue, timeout_s=timeout_s,
                        client=client_of(ctx))
        return Result(sim_time=app.service.sim_time, result=out)

    @tool(read_only=False, title="Queue a task")
    async def queue_task(ctx: Context, spec: TaskSpec = Field(description="the task: its type and that type's "
                         "params")) -> Result:
        """Queue a task for no robot in particular; assign_tasks hands the queue out."""
        svc = app_of(ctx).service
        d = spec.model_dump(exclude_unset=True)
        out = await run(ctx, svc.queue_task, d["type"], d["params"], priority=d.get("priority", 0),
                        earliest_start=d.get("earliest_start"), deadline=d.get("deadline"), id=d.get("id"))
        return Result(sim_time=svc.sim_time, result=out)

    @tool(read_only=False, title="Assign tasks")
    async def assign_tasks(ctx: Context, tasks: list[TaskSpec] | None = Field(None, max_length=200, description=
                           "omitted: the queue"),
                           robots: list[str] | None = Field(None, description="omitted: every idle robot"),
                           method: Literal["hungarian", "greedy", "auction"] = "hungarian",
                           dry_run: bool = Field(False, description="plan only: nothing is submitted"),
                           cost: Literal["path", "euclidean"] = "path",
                           response_format: ResponseFormat = "normal") -> Result:
        """Allocate tasks to robots: who does what in which order, ETAs, travel, charge stops and tasks that
        cannot be placed (with why). Unless dry_run, the tasks are submitted (task ids in each assignment)."""
        app = app_of(ctx)
        specs = None if tasks is None else [t.model_dump(exclude_unset=True) for t in tasks]
        alloc = await run(ctx, app.service.assign_tasks, specs, robots, method, dry_run, client=client_of(ctx),
                          cost=cost)
        d = alloc.to_dict()
        d["assignments"] = [_assignment_view(a, response_format) for a in d["assignments"]]
        return Result(sim_time=app.service.sim_time, result=d)

    @tool(read_only=True, title="List docks")
    async def list_docks(ctx: Context) -> Items:
        """Charging docks of the world (dock_* models)."""
        svc = app_of(ctx).service
        return Items(sim_time=svc.sim_time, items=await run(ctx, svc.list_docks))

    @tool(read_only=False, title="Start a swarm behaviour")
    async def start_swarm_behaviour(ctx: Context, behaviour: Literal["flocking", "coverage", "formation",
                                    "leader_follower", "rendezvous"], robots: list[str] | None = None,
                                    params: BehaviourParams = Field(None, description="the behaviour's "
                                    "settings (the alternative named after it); omitted: its defaults")) -> Result:
        """Run a swarm behaviour on robots (all by default); swarm_status reports its metric over time."""
        app = app_of(ctx)
        params = checked(behaviour_configs(), "behaviour", behaviour, params)
        out = await run(ctx, app.service.start_behaviour, behaviour, robots, params, client=client_of(ctx))
        return Result(sim_time=app.service.sim_time, result=out)

    @tool(read_only=False, idempotent=True, title="Stop a swarm behaviour")
    async def stop_swarm_behaviour(ctx: Context, behaviour_id: str) -> Result:
        """Stop a running swarm behaviour; its robots stop and its final metrics are kept."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.stop_behaviour, behaviour_id))

    @tool(read_only=True, title="Swarm behaviour status")
    async def swarm_status(ctx: Context, behaviour_id: str | None = Field(None, description="omitted: all running"),
                           history: bool = False) -> Items:
        """State and outcome metrics (e.g. order, spread, coverage, formation error) of behaviours."""
        svc = app_of(ctx).service
        out = await run(ctx, svc.behaviour_status, behaviour_id, history)
        return Items(sim_time=svc.sim_time, items=out if isinstance(out, list) else [out])

    @tool(read_only=True, title="Collision avoidance settings")
    async def get_collision_avoidance(ctx: Context) -> Result:
        """The multi-robot avoidance plugin in use and its settings."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.avoidance_settings))

    @tool(read_only=False, idempotent=True, title="Set collision avoidance")
    async def set_collision_avoidance(ctx: Context, plugin: Literal["orca", "none"] | None = Field(None, description=
                                      "plugin; omitted: keep the current one"),
                                      settings: AvoidanceSettings = Field(None, description="the "
                                      "plugin's settings (the alternative named after it); omitted fields keep "
                                      "their values")) -> Result:
        """Enable/disable multi-robot avoidance (orca | none) or tune it."""
        svc = app_of(ctx).service
        current = plugin or str((await run(ctx, svc.avoidance_settings))["type"])
        settings = checked(avoidance_configs(), "avoidance", current, settings)
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.set_avoidance, plugin, **(settings or {})))

    @tool(read_only=True, title="Deadlock report")
    async def deadlock_report(ctx: Context) -> Result:
        """Deadlocks detected, resolved and open, the robots involved and the policy in use."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.deadlock_report))

    @tool(read_only=False, idempotent=True, title="Configure deadlock handling")
    async def configure_deadlocks(ctx: Context, policy: Literal["priority", "replan", "none"] | None = None,
                                  settings: DeadlockConfig | None = Field(
                                      None, description="thresholds; omitted fields keep their values")) -> Result:
        """Change the deadlock policy (priority | replan | none) or its thresholds (wait_s, stall_s, ...)."""
        svc = app_of(ctx).service
        kw = (settings.model_dump(exclude_unset=True) if settings else {}) | ({"policy": policy} if policy else {})
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.configure_deadlocks, **kw))

    @tool(read_only=False, title="Visualise the robot network")
    async def visualize_robot_network(ctx: Context, view: Literal["comms", "formation", "collision_zones", "tasks"]
                                      = "comms", comm_range: float = Field(5.0, gt=0, le=1000),
                                      robots: list[str] | None = None,
                                      lifetime_s: float | None = Field(10.0, gt=0)) -> Result:
        """Draw the comms graph, formation lines, collision zones or task lines as debug markers (namespace
        `network`, visible in get_occupancy_map and recordings); returns the edges."""
        svc = app_of(ctx).service
        out = await run(ctx, svc.network_markers, view, comm_range, robots, lifetime_s)
        return Result(sim_time=svc.sim_time, result=out)
