"""Scripted events (`events:` in a mission file), each chosen by `type:` and fired once at sim time `at`.

An event does what it says through the FleetService (so it is recorded and published like any other
command) and returns one line saying what it did; a FleetError from it becomes a setup error of the run.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Literal

from pydantic import Field, model_validator

from fleet.missions.registry import Registry
from fleet.missions.types import PoseSpec, RunData
from sim.config import StrictModel
from sim.types import Pose3D

if TYPE_CHECKING:
    from fleet.service import FleetService

EventFn = Callable[..., str]
EVENTS: Registry[EventFn] = Registry("event type")
SENSORS = ("lidar", "imu", "odom", "camera")


class EventBase(StrictModel):
    type: str
    at: float = Field(ge=0, allow_inf_nan=False, description="sim time at which the event fires, s")


class SpawnObstacle(EventBase):
    type: Literal["spawn_obstacle"] = "spawn_obstacle"
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_\-]+$")
    shape: Literal["box", "cylinder"] = "box"
    size: tuple[float, float, float] = Field((0.5, 0.5, 1.0), description="box x y z, m")
    radius: float = Field(0.3, gt=0, description="cylinder radius, m")
    height: float = Field(1.0, gt=0, description="cylinder height, m (≥ 0.8 so the lidar sees it)")
    pose: PoseSpec

    @model_validator(mode="after")
    def _positive(self) -> SpawnObstacle:
        if min(self.size) <= 0:
            raise ValueError(f"size must be positive, got {list(self.size)}")
        return self


class RemoveObstacle(EventBase):
    type: Literal["remove_obstacle"] = "remove_obstacle"
    name: str


class SensorFault(EventBase):
    type: Literal["sensor_fault"] = "sensor_fault"
    robot: str
    sensor: Literal["lidar", "imu", "odom", "camera"]
    dropout: bool = Field(True, description="the sensor stops publishing")
    noise_scale: float = Field(1.0, ge=0, description="noise σ multiplier (1: nominal)")


class KillRobot(EventBase):
    type: Literal["kill_robot"] = "kill_robot"
    robot: str
    mode: Literal["halt", "remove"] = Field(
        "halt", description="halt: it stops dead where it is and stays as an obstacle; remove: it vanishes")


class Estop(EventBase):
    type: Literal["estop"] = "estop"
    robot: str | None = Field(None, description="null: the whole fleet")
    reason: str = "scripted e-stop"


class Rearm(EventBase):
    type: Literal["rearm"] = "rearm"
    robot: str | None = Field(None, description="null: the whole fleet")


class FleetCommand(EventBase):
    type: Literal["fleet_command"] = "fleet_command"
    command: Literal["move", "stop", "formation", "sync", "return_home"]
    robots: list[str] | None = None
    target: PoseSpec | None = None
    formation: str | None = None
    spacing: float | None = Field(None, gt=0)


class SetBattery(EventBase):
    type: Literal["set_battery"] = "set_battery"
    robot: str
    soc: float = Field(ge=0, le=1)


def obstacle_sdf(e: SpawnObstacle) -> str:
    geo = (f"<box><size>{e.size[0]} {e.size[1]} {e.size[2]}</size></box>" if e.shape == "box" else
           f"<cylinder><radius>{e.radius}</radius><length>{e.height}</length></cylinder>")
    return (f'<sdf version="1.6"><model name="{e.name}"><static>true</static><link name="link">'
            f"<collision name='c'><geometry>{geo}</geometry></collision>"
            f"<visual name='v'><geometry>{geo}</geometry></visual></link></model></sdf>")


def obstacle_pose(e: SpawnObstacle) -> Pose3D:
    z = (e.size[2] if e.shape == "box" else e.height) / 2  # standing on the ground
    return Pose3D(e.pose.x, e.pose.y, z, 0.0, 0.0, e.pose.yaw)


@EVENTS.register("spawn_obstacle", SpawnObstacle)
def spawn_obstacle(e: SpawnObstacle, svc: FleetService, data: RunData) -> str:
    svc.spawn_model(xml=obstacle_sdf(e), pose=obstacle_pose(e), static=True)
    return f"obstacle '{e.name}' ({e.shape}) at ({e.pose.x:.2f}, {e.pose.y:.2f})"


@EVENTS.register("remove_obstacle", RemoveObstacle)
def remove_obstacle(e: RemoveObstacle, svc: FleetService, data: RunData) -> str:
    svc.delete_model(e.name)
    return f"obstacle '{e.name}' removed"


@EVENTS.register("sensor_fault", SensorFault)
def sensor_fault(e: SensorFault, svc: FleetService, data: RunData) -> str:
    svc.call(lambda: svc.world.set_sensor_fault(e.robot, e.sensor, dropout=e.dropout, noise_scale=e.noise_scale))
    svc.events.publish(svc.world.time, "sensor_fault", (e.robot,), f"{e.robot} {e.sensor}: dropout={e.dropout}, "
                       f"noise×{e.noise_scale}", sensor=e.sensor, dropout=e.dropout, noise_scale=e.noise_scale)
    return f"{e.robot} {e.sensor} fault (dropout={e.dropout}, noise×{e.noise_scale:g})"


@EVENTS.register("kill_robot", KillRobot)
def kill_robot(e: KillRobot, svc: FleetService, data: RunData) -> str:
    data.removed[e.robot] = svc.world.time
    if e.mode == "remove":
        svc.remove_robot(e.robot)
        return f"{e.robot} removed from the world"
    svc.call(lambda: svc.control.release(e.robot, "robot killed"))
    svc.estop(e.robot, "robot killed")
    return f"{e.robot} killed (halted in place)"


@EVENTS.register("estop", Estop)
def estop(e: Estop, svc: FleetService, data: RunData) -> str:
    hit = svc.estop(e.robot, e.reason)
    return f"e-stop: {', '.join(hit) or 'no robots'}"


@EVENTS.register("rearm", Rearm)
def rearm(e: Rearm, svc: FleetService, data: RunData) -> str:
    changed = svc.rearm(e.robot)
    return f"re-armed {e.robot or 'the fleet'}" + ("" if changed else " (was not e-stopped)")


@EVENTS.register("fleet_command", FleetCommand)
def fleet_command(e: FleetCommand, svc: FleetService, data: RunData) -> str:
    out = svc.fleet_command(e.command, e.robots, target=e.target.pose() if e.target else None,
                            formation=e.formation, spacing=e.spacing)
    return f"fleet {e.command} for {', '.join(out['robots'])}"


@EVENTS.register("set_battery", SetBattery)
def set_battery(e: SetBattery, svc: FleetService, data: RunData) -> str:
    svc.set_battery(e.robot, e.soc)
    return f"{e.robot} battery set to {e.soc:.0%}"
