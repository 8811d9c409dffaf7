"""Robot tools: list and inspect robots, spawn/remove, drive through the safety envelope, e-stop and re-arm,
control leases, battery."""

from __future__ import annotations

import math
from typing import Any, Literal

from mcp.server.mcpserver import Context
from pydantic import Field

from mcp_server.app import app_of, client_of, run
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat, fleet_summary
from mcp_server.waiting import advance
from sim import Pose2D
from sim.transforms import wrap_angle


class RobotList(Answer):
    summary: dict[str, Any] | None = Field(None, description="response_format=summary: aggregates, no per-robot rows")
    robots: list[dict[str, Any]] | None = None
    total: int
    next_offset: int | None = None


class RobotState(Answer):
    robot: dict[str, Any]
    tasks: list[dict[str, Any]] | None = None


class Achieved(Answer):
    duration_s: float
    distance_m: float = Field(description="straight-line displacement")
    yaw_change_rad: float
    mean_v: float = Field(description="path-length proxy: displacement / time, m/s")
    mean_w: float
    final_pose: dict[str, float]
    final_twist: dict[str, float]


class DriveResult(Answer):
    robot: str
    requested: dict[str, float]
    applied: dict[str, float]
    clamped: bool
    reason: str
    achieved: Achieved | None = Field(None, description="what the robot did during `duration` (when wait=true)")


class EstopResult(Answer):
    robots: list[str]
    latched: bool


class Done(Answer):
    message: str


def _pose(p: Pose2D) -> dict[str, float]:
    return {"x": round(p.x, 4), "y": round(p.y, 4), "yaw": round(p.yaw, 4)}


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="List robots")
    async def list_robots(ctx: Context, response_format: ResponseFormat = "summary",
                          limit: int = Field(100, ge=1, le=1000), offset: int = Field(0, ge=0)) -> RobotList:
        """The fleet from the latest snapshot. summary: counts, aggregates, names as ranges and robots needing
        attention (stays small for hundreds of robots); normal: pose, speed, battery, controller per robot;
        full: also commands, fidelity, lease, namespace. normal/full are paged with limit/offset."""
        svc = app_of(ctx).service
        snap = svc.snapshot
        n = len(snap.names)
        if response_format == "summary":
            return RobotList(sim_time=snap.time, total=n,
                             summary=fleet_summary(snap, svc.config.battery.low_threshold))
        rows = [snap.robot(name).to_dict(response_format) for name in snap.names[offset:offset + limit]]
        more = offset + limit if offset + limit < n else None
        return RobotList(sim_time=snap.time, total=n, robots=rows, next_offset=more)

    @tool(read_only=True, title="Robot state")
    async def get_robot_state(ctx: Context, robot: str, response_format: ResponseFormat = "normal") -> RobotState:
        """One robot: pose, velocity, battery, controller, e-stop, collision, lease; normal/full add its tasks."""
        svc = app_of(ctx).service
        view = svc.robot(robot)
        tasks = None if response_format == "summary" else await run(ctx, svc.list_tasks, robot)
        if tasks is not None and response_format == "normal":
            tasks = [{k: t[k] for k in ("id", "type", "state", "progress")} for t in tasks]
        return RobotState(sim_time=svc.sim_time, robot=view.to_dict(response_format), tasks=tasks)

    @tool(read_only=False, title="Spawn a robot")
    async def spawn_robot(ctx: Context, name: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_\-]+$"),
                          x: float = 0.0, y: float = 0.0, yaw: float = 0.0, model: str | None = None,
                          fidelity: Literal["kinematic", "dynamic"] | None = None) -> RobotState:
        """Add a differential-drive robot at (x, y, yaw); the pose must be free of obstacles."""
        svc = app_of(ctx).service
        view = await run(ctx, svc.spawn_robot, name, Pose2D(x, y, yaw), model=model, fidelity=fidelity)
        return RobotState(sim_time=svc.sim_time, robot=view.to_dict("full"))

    @tool(read_only=False, destructive=True, title="Remove a robot")
    async def remove_robot(ctx: Context, robot: str) -> Done:
        """Take a robot out of the world; its tasks are canceled."""
        svc = app_of(ctx).service
        await run(ctx, svc.remove_robot, robot)
        return Done(sim_time=svc.sim_time, message=f"removed {robot}")

    @tool(read_only=False, title="Drive a robot")
    async def drive_robot(ctx: Context, robot: str, v: float = Field(description="forward speed, m/s"),
                          w: float = Field(description="yaw rate, rad/s (counter-clockwise +)"),
                          duration: float = Field(1.0, gt=0, le=60, description="sim seconds the command holds"),
                          wait: bool = Field(True, description="wait `duration` and report the achieved motion (on "
                                             "a paused clock the tool steps the simulation)")) -> DriveResult:
        """A velocity command through the safety envelope (limits clamp and say so); it takes the robot over
        from any task. Reports the applied command and, with wait, what the robot achieved."""
        app = app_of(ctx)
        svc = app.service
        before = svc.robot(robot)
        t0 = svc.sim_time
        cmd = await run(ctx, svc.drive, robot, v, w, client=client_of(ctx), duration=duration)
        out = DriveResult(sim_time=cmd.stamp, robot=robot, requested={"v": cmd.requested_v, "w": cmd.requested_w},
                          applied={"v": cmd.applied_v, "w": cmd.applied_w}, clamped=cmd.clamped, reason=cmd.reason)
        if not wait:
            return out
        await advance(ctx, duration, message=lambda: f"driving {robot}")
        after, t1 = svc.robot(robot), svc.sim_time
        dt = max(t1 - t0, 1e-9)
        dist = math.hypot(after.pose.x - before.pose.x, after.pose.y - before.pose.y)
        dyaw = wrap_angle(after.pose.yaw - before.pose.yaw)
        out.achieved = Achieved(sim_time=t1, duration_s=round(dt, 4), distance_m=round(dist, 4),
                                yaw_change_rad=round(dyaw, 4), mean_v=round(dist / dt, 4), mean_w=round(dyaw / dt, 4),
                                final_pose=_pose(after.pose),
                                final_twist={"v": round(after.v, 4), "w": round(after.w, 4)})
        out.sim_time = t1
        return out

    @tool(read_only=False, idempotent=True, title="Stop a robot")
    async def stop_robot(ctx: Context, robot: str) -> DriveResult:
        """Command zero velocity (a manual command: it takes the robot over from any task)."""
        app = app_of(ctx)
        cmd = await run(ctx, app.service.stop_robot, robot, client=client_of(ctx))
        return DriveResult(sim_time=cmd.stamp, robot=robot, requested={"v": 0.0, "w": 0.0},
                           applied={"v": cmd.applied_v, "w": cmd.applied_w}, clamped=cmd.clamped, reason=cmd.reason)

    @tool(read_only=False, destructive=True, idempotent=True, title="Emergency stop")
    async def emergency_stop(ctx: Context, robot: str | None = Field(None, description="omit to stop the whole "
                                                                     "fleet"),
                             reason: str = "e-stop via MCP") -> EstopResult:
        """Latched e-stop: the robot (or fleet) brakes at once and stays stopped until rearm."""
        svc = app_of(ctx).service
        robots = await run(ctx, svc.estop, robot, reason)
        return EstopResult(sim_time=svc.sim_time, robots=robots, latched=True)

    @tool(read_only=False, idempotent=True, title="Re-arm after an e-stop")
    async def rearm(ctx: Context, robot: str | None = Field(None, description="omit to re-arm the fleet e-stop")) \
            -> EstopResult:
        """Release a latched e-stop (robot or fleet); robots stay still until commanded again."""
        svc = app_of(ctx).service
        changed = await run(ctx, svc.rearm, robot)
        return EstopResult(sim_time=svc.sim_time, robots=[robot] if robot else [], latched=not changed
                           and any(svc.snapshot.estopped))

    @tool(read_only=False, title="Acquire a control lease")
    async def acquire_lease(ctx: Context, robot: str, ttl_s: float | None = Field(None, gt=0, le=3600)) -> Done:
        """Become the one client allowed to command this robot (others get LEASE_HELD) until released or the
        lease lapses."""
        app = app_of(ctx)
        await run(ctx, app.service.acquire_lease, client_of(ctx), robot, ttl_s)
        return Done(sim_time=app.service.sim_time, message=f"client '{client_of(ctx)}' holds {robot}")

    @tool(read_only=False, idempotent=True, title="Release a control lease")
    async def release_lease(ctx: Context, robot: str) -> Done:
        """Give up this client's control lease on a robot."""
        app = app_of(ctx)
        ok = await run(ctx, app.service.release_lease, client_of(ctx), robot)
        return Done(sim_time=app.service.sim_time, message=f"released {robot}" if ok else
                    f"client '{client_of(ctx)}' held no lease on {robot}")

    @tool(read_only=False, idempotent=True, title="Set battery charge")
    async def set_battery(ctx: Context, robot: str, soc: float = Field(ge=0, le=1, description="state of charge")) \
            -> RobotState:
        """Set a robot's state of charge (to test low-battery behaviour and charging)."""
        svc = app_of(ctx).service
        await run(ctx, svc.set_battery, robot, soc)
        return RobotState(sim_time=svc.sim_time, robot=svc.robot(robot).to_dict("normal"))
