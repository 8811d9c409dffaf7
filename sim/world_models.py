"""World edits the MCP and Zenoh layers need: spawn/delete models, model state, forces, physics settings."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pybullet as p

from sim.errors import ErrorCode, FleetError
from sim.types import Pose3D
from sim.world_types import ModelState

if TYPE_CHECKING:
    from sim.world import World


def _finite(name: str, values: tuple[float, ...]) -> None:
    if not all(math.isfinite(v) for v in values):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{name} must be finite, got {values}")


def spawn_model(world: World, *, name: str | None = None, file: str | None = None, xml: str | None = None,
                pose: Pose3D | None = None, static: bool | None = None,
                model_path: list[str] | None = None) -> list[str]:
    """Spawn from a URDF or SDF file, or an SDF/URDF XML string. Returns the names of models added."""
    if (file is None) == (xml is None):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "give exactly one of file or xml")
    text = Path(file).read_text(encoding="utf-8") if file is not None and Path(file).is_file() else xml
    if text is None:
        raise FleetError(ErrorCode.NOT_FOUND, f"no such file: {file}", "give a path inside the workspace")
    source = file or "<xml>"
    is_urdf = "<robot" in text[:2000] and "<sdf" not in text[:2000]
    if is_urdf:
        path = file
        if path is None:
            import tempfile

            path = str(Path(tempfile.mkdtemp(prefix="fleetnav_")) / "model.urdf")
            Path(path).write_text(text, encoding="utf-8")
        from sim.urdf_parser import parse_urdf

        robot = parse_urdf(text)  # validates with line numbers before PyBullet sees it
        model_name = name or robot.name
        _check_free_name(world, model_name)
        world.models.add_urdf(model_name, path, pose or Pose3D(), bool(static))
        world._sync_labels()
        return [model_name]
    from sim.sdf_parser import parse_sdf_string

    desc = parse_sdf_string(text, source=source, model_path=model_path)
    models = list(desc.models)
    if not models:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{source}: no <model> found")
    if name is not None:
        if len(models) != 1:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{source} holds {len(models)} models; name applies to one")
        models[0] = replace(models[0], name=name)
    if pose is not None:
        models = [replace(m, pose=pose.compose(m.pose) if len(models) > 1 else pose) for m in models]
    if static is not None:
        models = [replace(m, static=static) for m in models]
    for m in models:
        _check_free_name(world, m.name)
    for m in models:
        world.models.add_model(m)
    world._sync_labels()
    return [m.name for m in models]


def _check_free_name(world: World, name: str) -> None:
    if name in world.models.names() or world.table.has(name):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"name '{name}' is already in use", "pick another name")


def remove_model(world: World, name: str) -> None:
    if world.table.has(name):
        world.remove_robot(name)
        return
    world.models.remove(name)
    world._sync_labels()


def model_state(world: World, name: str) -> ModelState:
    if world.table.has(name):
        pose = world.robot_pose(name)
        v, w = world.robot_twist(name)
        return ModelState(name, Pose3D(pose.x, pose.y, 0.0, 0.0, 0.0, pose.yaw),
                          (v * math.cos(pose.yaw), v * math.sin(pose.yaw), 0.0), (0.0, 0.0, w), False, "robot")
    return world.models.state(name)


def set_model_state(world: World, name: str, pose: Pose3D | None = None,
                    linear: tuple[float, float, float] | None = None,
                    angular: tuple[float, float, float] | None = None) -> ModelState:
    for label, vec in (("linear velocity", linear), ("angular velocity", angular)):
        if vec is not None:
            _finite(label, tuple(vec))
    if world.table.has(name):
        if pose is not None:
            world.set_robot_pose(name, pose.to_2d())
        if linear is not None or angular is not None:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{name}' is a robot: set its velocity with a drive command",
                             "use set_cmd_vel / the drive tool")
    else:
        world.models.set_state(name, pose, linear, angular)
    return model_state(world, name)


def apply_force(world: World, name: str, force: tuple[float, float, float],
                torque: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
    """Apply a force (N) and torque (N·m) in the world frame at the model's base for the next step."""
    _finite("force", tuple(force))
    _finite("torque", tuple(torque))
    if world.table.has(name):
        if world.robot_fidelity(name) == "kinematic":
            raise FleetError(ErrorCode.UNSUPPORTED, f"'{name}' is a kinematic robot: forces do not act on it",
                             "spawn it with fidelity=dynamic")
        uid = world.bodies[name].uid
        pos, _ = p.getBasePositionAndOrientation(uid, physicsClientId=world.client)
        p.applyExternalForce(uid, -1, force, pos, p.WORLD_FRAME, physicsClientId=world.client)
        p.applyExternalTorque(uid, -1, torque, p.WORLD_FRAME, physicsClientId=world.client)
        return
    world.models.apply_force(name, force, torque)


def physics_properties(world: World) -> dict[str, Any]:
    params = p.getPhysicsEngineParameters(physicsClientId=world.client)
    gravity = [params[f"gravityAcceleration{axis}"] for axis in "XYZ"]
    return {"physics_hz": world.physics_hz, "time_step": world.dt, "gravity": gravity,
            "solver_iterations": params["numSolverIterations"], "fidelity": world.fidelity}


def set_physics_properties(world: World, *, gravity: tuple[float, float, float] | None = None,
                           solver_iterations: int | None = None) -> dict[str, Any]:
    if gravity is not None:
        _finite("gravity", tuple(gravity))
        p.setGravity(*gravity, physicsClientId=world.client)
    if solver_iterations is not None:
        if not 1 <= solver_iterations <= 1000:
            raise FleetError(ErrorCode.INVALID_ARGUMENT,
                             f"solver_iterations must be in [1, 1000], got {solver_iterations}")
        p.setPhysicsEngineParameter(numSolverIterations=solver_iterations, physicsClientId=world.client)
    return physics_properties(world)
