"""Simulation tools: status, clock, stepping, reset, performance, worlds, snapshots."""

from __future__ import annotations

from typing import Any

from mcp.server.mcpserver import Context
from pydantic import Field

from fleet.validation import MAX_SPEED, MAX_STEPS, MIN_SPEED
from mcp_server.app import app_of, run
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import OVERWRITE, Answer
from sim.errors import ErrorCode, FleetError


class SimStatus(Answer):
    world: str
    clock: str
    speed: float
    robots: int
    models: int
    real_time_factor: float | None
    physics_hz: float
    control_hz: float
    step_count: int
    world_file: str


class SimTime(Answer):
    step_count: int
    clock: str


class Performance(Answer):
    steps: int
    step_ms: float
    real_time_factor: float | None
    robots: int
    hotspots: list[dict[str, Any]]


class WorldList(Answer):
    worlds: list[dict[str, str]]


class Snapshots(Answer):
    snapshots: list[dict[str, Any]]


class Done(Answer):
    message: str


class HealthOut(Answer):
    """alive false: every world call fails with SIM_DEAD (dead_reason says why; restart_simulation)."""

    alive: bool
    dead_reason: str | None
    command: str | None
    busy_for_s: float | None
    command_errors: int
    overruns: int
    tick_errors: int
    last_error: str | None
    restarts: int
    recent_errors: list[str]
    last_snapshot: str | None


class Restarted(Answer):
    restored_from: str
    robots: list[str]
    skipped: list[str] = Field(description="robots or snapshot that could not be brought back, with why")
    restarts: int


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="Simulation status")
    async def sim_status(ctx: Context) -> SimStatus:
        """World, clock mode, speed, robot and model counts, real-time factor, physics and control rates."""
        svc = app_of(ctx).service
        s = await run(ctx, svc.status)
        return SimStatus(sim_time=s["time"], world=s["world"], clock=svc.clock.mode.value, speed=s["speed"],
                         robots=s["robots"], models=s["models"], real_time_factor=s["real_time_factor"],
                         physics_hz=s["physics_hz"], control_hz=s["control_hz"], step_count=s["step_count"],
                         world_file=s["world_file"])

    @tool(read_only=False, idempotent=True, title="Pause the simulation")
    async def pause_simulation(ctx: Context) -> SimTime:
        """Stop sim time (robots freeze; commands are still accepted and apply when time runs again)."""
        svc = app_of(ctx).service
        await run(ctx, svc.pause)
        return SimTime(sim_time=svc.sim_time, step_count=svc.snapshot.step_count, clock="paused")

    @tool(read_only=False, idempotent=True, title="Run the simulation")
    async def unpause_simulation(ctx: Context, speed: float | None = Field(None, ge=MIN_SPEED, le=MAX_SPEED,
                                 description="real-time factor to run at; omitted keeps the current one")) -> SimTime:
        """Let sim time run at real time × speed."""
        svc = app_of(ctx).service
        await run(ctx, svc.resume, speed)
        return SimTime(sim_time=svc.sim_time, step_count=svc.snapshot.step_count, clock="realtime")

    @tool(read_only=False, idempotent=True, title="Set simulation speed")
    async def set_simulation_speed(ctx: Context, speed: float = Field(ge=MIN_SPEED, le=MAX_SPEED,
                                   description="sim seconds per wall second")) -> SimTime:
        """Change the real-time factor the clock aims for (it keeps its mode)."""
        svc = app_of(ctx).service
        await run(ctx, svc.set_speed, speed)
        return SimTime(sim_time=svc.sim_time, step_count=svc.snapshot.step_count, clock=svc.clock.mode.value)

    @tool(read_only=False, title="Step the simulation")
    async def step_simulation(ctx: Context, steps: int = Field(1, ge=1, le=MAX_STEPS,
                              description="physics steps (1/physics_hz s each)")) -> SimTime:
        """Advance exactly `steps` physics steps now, as fast as possible, then report the sim time."""
        svc = app_of(ctx).service

        def do() -> tuple[float, int]:
            return svc.step(steps), svc.world.step_count

        t, count = await run(ctx, do)
        return SimTime(sim_time=t, step_count=count, clock=svc.clock.mode.value)

    @tool(read_only=False, destructive=True, title="Reset the world")
    async def reset_simulation(ctx: Context) -> Done:
        """Rebuild the world from its file: every robot removed, tasks canceled, sim time 0."""
        svc = app_of(ctx).service
        await run(ctx, svc.reset)
        return Done(sim_time=svc.sim_time, message=f"world {svc.world.name} reset")

    @tool(read_only=True, title="Simulation performance")
    async def profile_simulation(ctx: Context, steps: int = Field(100, ge=1, le=10_000, description="physics steps "
                                 "to time; the world is put back afterwards")) -> Performance:
        """Run `steps` steps under a profiler: step cost, real-time factor and where the time goes."""
        svc = app_of(ctx).service
        p = await run(ctx, svc.performance, steps)
        return Performance(sim_time=svc.sim_time, steps=p["steps"], step_ms=p["step_ms"],
                           real_time_factor=p["real_time_factor"], robots=p["robots"], hotspots=p["hotspots"])

    @tool(read_only=True, title="Simulation health")
    async def sim_health(ctx: Context) -> HealthOut:
        """Is the sim thread alive, what is it running, which commands failed or overran, and why it died."""
        h = app_of(ctx).service.sim_health()  # answered without the sim thread, so it works when that is stuck
        return HealthOut(**h)

    @tool(read_only=False, destructive=True, title="Restart the simulation")
    async def restart_simulation(ctx: Context) -> Restarted:
        """Rebuild the world after SIM_DEAD (or on demand): the world file again, then the last saved snapshot
        (else the robots at their last poses). Tasks are canceled."""
        import anyio

        svc = app_of(ctx).service
        return Restarted(**await anyio.to_thread.run_sync(svc.restart))

    @tool(read_only=True, title="List worlds")
    async def list_worlds(ctx: Context) -> WorldList:
        """The shipped worlds (configs/worlds) that load_world accepts by name."""
        svc = app_of(ctx).service
        return WorldList(sim_time=svc.sim_time, worlds=svc.list_worlds())

    @tool(read_only=False, destructive=True, title="Load a world")
    async def load_world(ctx: Context, world: str = Field(description="a shipped world name, or an SDF file path "
                                                                      "inside the workspace")) -> Done:
        """Replace the world with another SDF world (robots are removed, tasks canceled)."""
        svc = app_of(ctx).service
        await run(ctx, svc.load_world, world)
        return Done(sim_time=svc.sim_time, message=f"loaded {svc.world_path}")

    @tool(read_only=False, title="Save the world as SDF")
    async def save_world(ctx: Context, path: str = Field(description="output .world path in the outputs area"),
                         overwrite: bool = OVERWRITE) -> Done:
        """Write the current world (models at their current poses) as an SDF 1.9 file."""
        if not path.endswith((".world", ".sdf")):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a world file ends in .world or .sdf, got '{path}'",
                             "e.g. saved/arena.world")
        svc = app_of(ctx).service
        if overwrite:
            svc.workspace.permit_overwrite(path)
        out = await run(ctx, svc.save_world, path)
        return Done(sim_time=svc.sim_time, message=f"saved {out}")

    @tool(read_only=False, title="Save a snapshot")
    async def save_snapshot(ctx: Context, name: str = Field(min_length=1, max_length=64)) -> Done:
        """Remember the exact world state (poses, velocities, sensors, time, RNG, batteries) under a name."""
        svc = app_of(ctx).service
        s = await run(ctx, svc.save_snapshot, name)
        return Done(sim_time=s["time"], message=f"snapshot '{name}' saved with {len(s['robots'])} robots")

    @tool(read_only=False, destructive=True, title="Restore a snapshot")
    async def restore_snapshot(ctx: Context, name: str) -> Done:
        """Go back exactly to a saved snapshot; running tasks are canceled."""
        svc = app_of(ctx).service
        s = await run(ctx, svc.restore_snapshot, name)
        return Done(sim_time=s["time"], message=f"restored '{name}'")

    @tool(read_only=True, title="List snapshots")
    async def list_snapshots(ctx: Context) -> Snapshots:
        """Saved snapshots with their sim time and robots."""
        svc = app_of(ctx).service
        return Snapshots(sim_time=svc.sim_time, snapshots=await run(ctx, svc.list_snapshots))
