"""Navigation tools: plan (preview), navigate, waypoints, coverage, task status/wait/cancel, the occupancy
map as an image, keep-out zones, the available planners and controllers."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from mcp.server.mcpserver import Context
from mcp_types import CallToolResult
from pydantic import BaseModel, Field

from mcp_server.app import app_of, client_of, run
from mcp_server.imaging import image_result
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat, path_payload, r3
from mcp_server.waiting import advance
from sim import Pose2D

XY = tuple[float, float]


class WaypointIn(BaseModel):
    x: float
    y: float
    yaw: float | None = Field(None, description="heading to reach at this waypoint (omitted: any)")
    dwell_s: float | None = Field(None, ge=0, le=3600)


class Plan(Answer):
    robot: str
    planner: str
    length_m: float
    planning_time_s: float
    start: dict[str, float]
    goal: dict[str, float]
    path: dict[str, Any] = Field(description="simplified polyline (normal), endpoints (summary) or every point")
    marker: str | None = Field(None, description="id of the debug marker drawing it (show=true)")


class TaskInfo(Answer):
    task: dict[str, Any]


class TaskWait(Answer):
    task: dict[str, Any]
    done: bool = Field(description="false: still running when the wait ended; call wait_for_task again")


class TaskList(Answer):
    tasks: list[dict[str, Any]]


class MapMeta(Answer):
    layer: str
    width: int
    height: int
    metres_per_pixel: float
    origin: list[float]
    bounds: list[float]
    orientation: str
    robots: int
    markers: int
    cell_resolution: float


class Keepouts(Answer):
    zones: int
    polygons: list[list[list[float]]] | None = None


class NavOptions(Answer):
    planners: list[str]
    controllers: list[str]
    task_types: list[str]
    defaults: dict[str, Any]


def task_view(t: dict[str, Any], fmt: ResponseFormat) -> dict[str, Any]:
    keys = ("id", "type", "robot", "state", "reason", "progress")
    if fmt == "summary":
        return {k: t.get(k) for k in keys}
    if fmt == "normal":
        return {k: t.get(k) for k in (*keys, "priority", "created", "started", "finished")}
    return t


def _pose(p: Pose2D) -> dict[str, float]:
    return {"x": r3(p.x) or 0.0, "y": r3(p.y) or 0.0, "yaw": r3(p.yaw) or 0.0}


def _nav(planner: str | None, controller: str | None) -> dict[str, Any]:
    """Navigation overrides for a task, checked now (a navigator is built only when the task starts)."""
    from planning import controller_names, planner_names
    from sim.errors import ErrorCode, unknown_name

    if planner and planner not in planner_names():
        raise unknown_name("planner", planner, planner_names(), ErrorCode.INVALID_ARGUMENT)
    if controller and controller not in controller_names():
        raise unknown_name("controller", controller, controller_names(), ErrorCode.INVALID_ARGUMENT)
    nav: dict[str, Any] = {}
    if planner:
        nav["planner"] = {"type": planner}
    if controller:
        nav["controller"] = {"type": controller}
    return {"navigation": nav} if nav else {}


PLANNER = Field(None, description="global planner (navigation_options lists them); omitted: configured default")
CONTROLLER = Field(None, description="path tracking controller; omitted: configured default")


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="Plan a path (preview)")
    async def plan_path(ctx: Context, robot: str, x: float, y: float, yaw: float = 0.0,
                        planner: str | None = PLANNER, response_format: ResponseFormat = "normal",
                        show: bool = Field(False, description="also draw it as a debug marker")) -> Plan:
        """Plan from the robot's pose to (x, y, yaw) on its costmap; nothing moves."""
        svc = app_of(ctx).service
        res = await run(ctx, svc.plan_path, robot, Pose2D(x, y, yaw), planner)
        marker = None
        if show:
            marker = (await run(ctx, svc.add_marker, "path", res.path.tolist(), colour="blue", ns="plans",
                                text=f"{robot} plan"))["id"]
        return Plan(sim_time=svc.sim_time, robot=robot, planner=res.planner, length_m=round(res.length, 3),
                    planning_time_s=round(res.planning_time_s, 4), start=_pose(res.start), goal=_pose(res.goal),
                    path=path_payload(res.path, response_format), marker=marker)

    @tool(read_only=False, title="Navigate to a pose")
    async def navigate_to(ctx: Context, robot: str, x: float, y: float, yaw: float = 0.0,
                          align_yaw: bool = Field(False, description="also turn to `yaw` at the goal"),
                          planner: str | None = PLANNER, controller: str | None = CONTROLLER) -> TaskInfo:
        """Start navigating (plan → track → replan → recover). Returns the task id at once: follow it with
        task_status or wait_for_task; cancel with cancel_task."""
        app = app_of(ctx)
        params = {"goal": Pose2D(x, y, yaw), "align_yaw": align_yaw} | _nav(planner, controller)
        t = await run(ctx, app.service.submit_task, "go_to", robot, params, client=client_of(ctx))
        return TaskInfo(sim_time=app.service.sim_time, task=task_view(t, "normal"))

    @tool(read_only=False, title="Follow waypoints")
    async def follow_waypoints(ctx: Context, robot: str, waypoints: list[WaypointIn] = Field(min_length=1,
                               max_length=500), mode: Literal["sequence", "loop", "patrol"] = "sequence",
                               rounds: int | None = Field(1, ge=1, le=1000, description="loop/patrol rounds; "
                                                          "null: forever"),
                               dwell_s: float = Field(0.0, ge=0, le=3600), skip_failed: bool = False) -> TaskInfo:
        """Visit waypoints in order (sequence), then back to the first (loop), or back and forth (patrol).
        Returns the task id at once; its progress counts waypoints and rounds."""
        app = app_of(ctx)
        wps = [w.model_dump(exclude_none=True) | ({"use_yaw": True} if w.yaw is not None else {}) for w in waypoints]
        t = await run(ctx, app.service.follow_waypoints, robot, wps, mode=mode, rounds=rounds, dwell_s=dwell_s,
                      skip_failed=skip_failed, client=client_of(ctx))
        return TaskInfo(sim_time=app.service.sim_time, task=task_view(t, "normal"))

    @tool(read_only=False, title="Cover an area")
    async def cover_area(ctx: Context, robot: str, polygon: list[XY] = Field(min_length=3, max_length=200,
                         description="area outline [[x, y], ...], m"), holes: list[list[XY]] = Field(
                         default_factory=list, max_length=50), tool_width: float = Field(0.5, gt=0.05, le=5),
                         pattern: Literal["boustrophedon", "spiral"] = "boustrophedon") -> TaskInfo:
        """Plan a coverage path over the polygon and drive it; progress reports the coverage measured from the
        robot's actual trajectory. Returns the task id at once."""
        app = app_of(ctx)
        t = await run(ctx, app.service.cover_area, robot, polygon, holes=holes, tool_width=tool_width,
                      pattern=pattern, client=client_of(ctx))
        return TaskInfo(sim_time=app.service.sim_time, task=task_view(t, "normal"))

    @tool(read_only=True, title="Task status")
    async def task_status(ctx: Context, task_id: str, response_format: ResponseFormat = "normal") -> TaskInfo:
        """State (queued, active, succeeded, failed, canceled), reason and progress (distance remaining, ETA,
        replans, waypoints, coverage...)."""
        svc = app_of(ctx).service
        return TaskInfo(sim_time=svc.sim_time, task=task_view(await run(ctx, svc.task_status, task_id),
                                                                   response_format))

    @tool(read_only=False, title="Wait for a task")
    async def wait_for_task(ctx: Context, task_id: str, timeout_s: float = Field(60.0, gt=0, le=3600,
                            description="sim seconds to wait at most"),
                            max_wall_s: float = Field(60.0, gt=0, le=600, description="wall seconds at most")) \
            -> TaskWait:
        """Wait until the task ends (or the timeout), sending progress notifications. On a paused clock the
        tool steps the simulation itself, so this also drives batch runs."""
        svc = app_of(ctx).service
        state: dict[str, Any] = await run(ctx, svc.task_status, task_id)

        async def done() -> bool:
            state.update(await run(ctx, svc.task_status, task_id))
            return state["state"] in ("succeeded", "failed", "canceled")

        def message() -> str:
            p = state.get("progress") or {}
            left = p.get("distance_remaining")
            return f"{state['state']}" + (f", {left:.1f} m to go" if isinstance(left, int | float) else "")

        finished = await advance(ctx, timeout_s, done=done, message=message, max_wall_s=max_wall_s)
        return TaskWait(sim_time=svc.sim_time, task=task_view(state, "normal"), done=finished)

    @tool(read_only=False, idempotent=True, title="Cancel a task")
    async def cancel_task(ctx: Context, task_id: str) -> TaskInfo:
        """Cancel a queued or running task (the robot stops)."""
        svc = app_of(ctx).service
        return TaskInfo(sim_time=svc.sim_time, task=task_view(await run(ctx, svc.cancel_task, task_id), "normal"))

    @tool(read_only=True, title="List tasks")
    async def list_tasks(ctx: Context, robot: str | None = None, include_done: bool = False,
                         response_format: ResponseFormat = "summary",
                         limit: int = Field(50, ge=1, le=1000)) -> TaskList:
        """Queued and active tasks (and finished ones with include_done), newest last."""
        svc = app_of(ctx).service
        tasks = await run(ctx, svc.list_tasks, robot, include_done)
        return TaskList(sim_time=svc.sim_time, tasks=[task_view(t, response_format) for t in tasks[-limit:]])

    @tool(read_only=True, title="Occupancy map image")
    async def get_occupancy_map(ctx: Context, robot: str | None = Field(None, description="that robot's costmap "
                                "(inflation, keep-outs, lidar obstacles); omitted: the static map"),
                                max_px: int = Field(800, ge=64, le=4096), show_robots: bool = True,
                                show_markers: bool = True) -> Annotated[CallToolResult, MapMeta]:
        """The map as a PNG (north up; obstacles black, inflation blue, keep-outs red, robots orange, goals
        green, debug markers in their colours) with the pixel ↔ map conversion."""
        svc = app_of(ctx).service
        png, meta = await run(ctx, svc.map_image, robot, show_robots=show_robots, show_markers=show_markers,
                              max_px=max_px)
        return image_result(png, MapMeta(sim_time=svc.sim_time, **meta))

    @tool(read_only=False, title="Add a keep-out zone")
    async def add_keepout_zone(ctx: Context, polygon: list[XY] = Field(min_length=3, max_length=200)) -> Keepouts:
        """Forbid a polygon to every robot's planner (robots spawned later too); running navigations replan."""
        svc = app_of(ctx).service
        n = await run(ctx, svc.add_keepout, polygon)
        return Keepouts(sim_time=svc.sim_time, zones=n)

    @tool(read_only=False, destructive=True, idempotent=True, title="Clear keep-out zones")
    async def clear_keepout_zones(ctx: Context) -> Keepouts:
        """Remove every keep-out zone from every robot's costmap."""
        svc = app_of(ctx).service
        await run(ctx, svc.clear_keepouts)
        return Keepouts(sim_time=svc.sim_time, zones=0)

    @tool(read_only=True, title="List keep-out zones")
    async def list_keepout_zones(ctx: Context) -> Keepouts:
        """The keep-out polygons in force."""
        svc = app_of(ctx).service
        zones = await run(ctx, svc.list_keepouts)
        return Keepouts(sim_time=svc.sim_time, zones=len(zones),
                        polygons=[[[r3(x), r3(y)] for x, y in z] for z in zones])

    @tool(read_only=True, title="Navigation options")
    async def navigation_options(ctx: Context) -> NavOptions:
        """Planners, controllers and task types available, and the navigation defaults in use."""
        from fleet.tasks import task_types
        from planning import controller_names, planner_names

        svc = app_of(ctx).service
        return NavOptions(sim_time=svc.sim_time, planners=planner_names(), controllers=controller_names(),
                          task_types=task_types(), defaults=svc.nav_config().model_dump(mode="json"))
