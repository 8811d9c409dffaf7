"""World and model tools: list/spawn/delete models, model state, forces, physics and gravity, world files."""

from __future__ import annotations

from typing import Any, Literal

import anyio
from mcp.server.mcpserver import Context
from pydantic import BaseModel, Field

from mcp_server.app import app_of, run
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat, compress_names
from sim import ModelState, Pose3D
from sim.errors import ErrorCode, FleetError

GRAVITY_PRESETS = {"earth": (0.0, 0.0, -9.81), "moon": (0.0, 0.0, -1.62), "mars": (0.0, 0.0, -3.71),
                   "zero": (0.0, 0.0, 0.0)}


class PoseIn(BaseModel):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0

    def pose(self) -> Pose3D:
        return Pose3D(self.x, self.y, self.z, self.roll, self.pitch, self.yaw)


Vec3 = tuple[float, float, float]


class ModelList(Answer):
    count: int
    by_kind: dict[str, int]
    names: str | None = Field(None, description="summary: names as ranges")
    models: list[dict[str, Any]] | None = None


class ModelStateOut(Answer):
    name: str
    kind: str
    static: bool
    pose: dict[str, float]
    linear_velocity: list[float]
    angular_velocity: list[float]


class Spawned(Answer):
    models: list[str]


class Done(Answer):
    message: str


class Physics(Answer):
    physics_hz: float
    time_step: float
    gravity: list[float]
    solver_iterations: int
    fidelity: str


class WorldInfo(Answer):
    world: str
    bounds: list[float] = Field(description="xmin, ymin, xmax, ymax of the obstacles, m")
    models: int
    obstacles: int
    spawn_points: list[dict[str, Any]]
    docks: list[dict[str, Any]]
    lights: int
    physics: dict[str, Any]
    unsupported: list[str]


class WorldCheck(Answer):
    path: str
    world: str
    sdf_version: str
    models: int
    obstacles: int
    spawn_points: list[str]
    unsupported: list[str]


def _state(s: ModelState, t: float) -> ModelStateOut:
    p = s.pose
    return ModelStateOut(sim_time=t, name=s.name, kind=s.kind, static=s.static,
                         pose={k: round(getattr(p, k), 4) for k in ("x", "y", "z", "roll", "pitch", "yaw")},
                         linear_velocity=[round(v, 4) for v in s.linear_velocity],
                         angular_velocity=[round(v, 4) for v in s.angular_velocity])


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="List models")
    async def list_models(ctx: Context, response_format: ResponseFormat = "summary",
                          kind: Literal["sdf", "urdf", "ground", "robot"] | None = None) -> ModelList:
        """Models in the world (robots included, kind=robot). summary: counts and names; normal: name, kind,
        x, y; full: whole 3-D pose and velocities."""
        svc = app_of(ctx).service
        states = [s for s in await run(ctx, svc.list_models) if kind is None or s.kind == kind]
        by_kind: dict[str, int] = {}
        for s in states:
            by_kind[s.kind] = by_kind.get(s.kind, 0) + 1
        t = svc.sim_time
        if response_format == "summary":
            names = compress_names([s.name for s in states])
            return ModelList(sim_time=t, count=len(states), by_kind=by_kind, names=names)
        if response_format == "normal":
            rows = [{"name": s.name, "kind": s.kind, "x": round(s.pose.x, 3), "y": round(s.pose.y, 3)} for s in states]
        else:
            rows = [_state(s, t).model_dump(exclude={"sim_time"}) for s in states]
        return ModelList(sim_time=t, count=len(states), by_kind=by_kind, models=rows)

    @tool(read_only=False, title="Spawn a model")
    async def spawn_model(ctx: Context, file: str | None = Field(None, description="URDF or SDF file inside the "
                          "workspace"), xml: str | None = Field(None, description="SDF or URDF XML text"),
                          name: str | None = Field(None, description="overrides the model's name (one model only)"),
                          pose: PoseIn | None = None, static: bool | None = None) -> Spawned:
        """Add a model from a URDF/SDF file or an XML string; the maps and planners see it at once."""
        svc = app_of(ctx).service
        names = await run(ctx, svc.spawn_model, name=name, file=file, xml=xml,
                          pose=pose.pose() if pose else None, static=static)
        return Spawned(sim_time=svc.sim_time, models=names)

    @tool(read_only=False, destructive=True, title="Delete a model")
    async def delete_model(ctx: Context, name: str) -> Done:
        """Remove a (non-robot) model from the world; use remove_robot for robots."""
        svc = app_of(ctx).service
        await run(ctx, svc.delete_model, name)
        return Done(sim_time=svc.sim_time, message=f"deleted {name}")

    @tool(read_only=True, title="Model state")
    async def get_model_state(ctx: Context, name: str) -> ModelStateOut:
        """A model's (or robot's) pose and linear/angular velocity in the world frame."""
        svc = app_of(ctx).service
        return _state(await run(ctx, svc.get_model_state, name), svc.sim_time)

    @tool(read_only=False, title="Set model state")
    async def set_model_state(ctx: Context, name: str, pose: PoseIn | None = None,
                              linear_velocity: Vec3 | None = None,
                              angular_velocity: Vec3 | None = None) -> ModelStateOut:
        """Teleport a model and/or set its velocity (robots: pose only; drive them with drive_robot)."""
        svc = app_of(ctx).service
        st = await run(ctx, svc.set_model_state, name, pose.pose() if pose else None, linear_velocity,
                       angular_velocity)
        return _state(st, svc.sim_time)

    @tool(read_only=False, title="Apply force and torque")
    async def apply_force(ctx: Context, name: str, force: Vec3 = Field(description="N, world frame"),
                          torque: Vec3 = Field((0.0, 0.0, 0.0), description="N·m, world frame")) -> Done:
        """Push a dynamic model (or dynamic robot) for the next physics step."""
        svc = app_of(ctx).service
        await run(ctx, svc.apply_force, name, force, torque)
        return Done(sim_time=svc.sim_time, message=f"applied force {list(force)} N, torque {list(torque)} N·m "
                    f"to {name}")

    @tool(read_only=True, title="World properties")
    async def get_world_properties(ctx: Context) -> WorldInfo:
        """Bounds, models, spawn points, docks, lights and physics settings of the loaded world."""
        svc = app_of(ctx).service

        def info() -> dict[str, Any]:
            d = svc.world.description
            return {"world": d.name, "bounds": [round(v, 3) for v in d.bounds()], "models": len(d.models),
                    "obstacles": len(d.obstacle_models()), "lights": len(d.lights),
                    "spawn_points": [{"name": s.name, "x": s.pose.x, "y": s.pose.y, "yaw": s.pose.yaw}
                                     for s in d.spawn_points],
                    "docks": svc.list_docks(), "physics": svc.world.physics_properties(),
                    "unsupported": list(d.unsupported)[:20]}

        return WorldInfo(sim_time=svc.sim_time, **await run(ctx, info))

    @tool(read_only=True, title="Physics properties")
    async def get_physics_properties(ctx: Context) -> Physics:
        """Physics rate, time step, gravity, solver iterations and fidelity."""
        svc = app_of(ctx).service
        return Physics(sim_time=svc.sim_time, **await run(ctx, svc.physics_properties))

    @tool(read_only=False, idempotent=True, title="Set physics properties")
    async def set_physics_properties(ctx: Context, gravity: Vec3 | None = Field(None, description="m/s²"),
                                     solver_iterations: int | None = Field(None, ge=1, le=1000)) -> Physics:
        """Change gravity and/or the solver iterations (dynamic bodies feel it; kinematic robots do not)."""
        svc = app_of(ctx).service
        out = await run(ctx, svc.set_physics_properties, gravity=gravity, solver_iterations=solver_iterations)
        return Physics(sim_time=svc.sim_time, **out)

    @tool(read_only=False, idempotent=True, title="Set gravity")
    async def set_gravity(ctx: Context, preset: Literal["earth", "moon", "mars", "zero", "custom"] = "earth",
                          vector: Vec3 | None = Field(None, description="m/s², with preset=custom")) -> Physics:
        """Gravity from a preset (earth, moon, mars, zero) or a custom vector."""
        if (preset == "custom") != (vector is not None):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "give `vector` exactly when preset is custom",
                             f"presets: {', '.join(GRAVITY_PRESETS)}, custom")
        svc = app_of(ctx).service
        g = vector if vector is not None else GRAVITY_PRESETS[preset]
        return Physics(sim_time=svc.sim_time, **await run(ctx, svc.set_physics_properties, gravity=g))

    @tool(read_only=True, title="Validate a world file")
    async def validate_world(ctx: Context, world: str = Field(description="a shipped world name or an SDF path "
                                                                          "inside the workspace")) -> WorldCheck:
        """Parse an SDF world without loading it: models, obstacles, spawn points, unsupported elements."""
        from sim import parse_sdf
        from sim.read_policy import policy

        svc = app_of(ctx).service
        path = svc.workspace.world(world)

        def parse() -> Any:
            with policy(svc.workspace.readable):  # includes and meshes stay inside the workspace too
                return parse_sdf(str(path))

        d = await anyio.to_thread.run_sync(parse)  # parsing needs no world: off the sim thread
        return WorldCheck(sim_time=svc.sim_time, path=str(path), world=d.name, sdf_version=d.sdf_version,
                          models=len(d.models), obstacles=len(d.obstacle_models()),
                          spawn_points=[s.name for s in d.spawn_points], unsupported=list(d.unsupported)[:50])
