"""FleetService operations on robots: spawn/remove, state, manual drive, e-stop, leases, sensors."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from fleet import validation
from fleet.core import ServiceCore
from fleet.registry import RobotRecord
from fleet.safety import AUTONOMY
from fleet.types import RobotView
from sim import CameraImage, FleetError, Pose2D
from sim.errors import ErrorCode
from sim.world_types import CommandResult

if TYPE_CHECKING:
    pass

SENSORS = ("lidar", "imu", "odom", "contact", "camera", "depth", "pose")


class RobotOps(ServiceCore):
    """Mixed into FleetService: every method runs its world access on the sim thread."""

    def spawn_robot(self, name: str, pose: Pose2D, *, model: str | None = None,
                    fidelity: str | None = None, namespace: str | None = None) -> RobotView:
        validation.pose("pose", pose, self.bounds)
        spec = self.default_spec(self.workspace.robot(model) if model is not None else None)

        def do() -> RobotView:
            self.world.spawn_robot(name, pose, spec=spec, fidelity=fidelity)  # type: ignore[arg-type]
            self.registry.add(RobotRecord(name, model or self.config.robot_model, namespace or name, pose,
                                          self.world.robot_fidelity(name), self.world.time))
            self.battery.resize(self.world.robot_names(), [n for n in self.world.robot_names() if n != name], {})
            self.events.publish(self.world.time, "robot_spawned", (name,), f"{name} at ({pose.x:.2f}, {pose.y:.2f})")
            self._publish()
            return self.snapshot.robot(name)

        return self.call(do)

    def remove_robot(self, name: str) -> None:
        def do() -> None:
            self.registry.get(name)
            self.control.release(name, "robot removed")
            before = self.world.robot_names()
            self.world.remove_robot(name)
            self.registry.remove(name)
            self.safety.leases.pop(name, None)
            self.safety.manual.pop(name, None)
            self.battery.resize(self.world.robot_names(), before, {})
            self.events.publish(self.world.time, "robot_removed", (name,), f"{name} removed")
            self._publish()

        self.call(do)

    def robot(self, name: str) -> RobotView:
        return self.snapshot.robot(name)

    def robot_names(self) -> list[str]:
        return list(self.snapshot.names)

    def drive(self, robot: str, v: float, w: float, *, client: str = "default",
              duration: float | None = None) -> CommandResult:
        """A manual velocity command through the safety envelope. It holds for `duration` sim seconds (default:
        the deadman timeout) unless renewed; it takes over the robot from any task or behaviour."""
        if duration is not None and not (math.isfinite(duration) and 0 < duration <= 3600):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"duration must be in (0, 3600] s, got {duration}")
        validation.finite("v", v, validation.MAX_VELOCITY)
        validation.finite("w", w, validation.MAX_VELOCITY)

        def do() -> CommandResult:
            self.registry.get(robot)
            spec = self.world.robot_spec(robot)
            limits = (spec.limits.max_linear, spec.limits.max_angular)
            av, aw, clamped, reason = self.safety.manual_command(client, robot, v, w, limits, self.world.time,
                                                                 duration)
            if self.control.owner(robot) not in ("idle", "manual"):
                self.control.release(robot, f"manual takeover by client '{client}'")
            self.control.apply_manual(robot)  # the next physics step integrates it (issue 17)
            return CommandResult(robot, v, w, av, aw, clamped, reason, self.world.time)

        return self.call(do)

    def stop_robot(self, robot: str, *, client: str = "default") -> CommandResult:
        return self.drive(robot, 0.0, 0.0, client=client)

    def estop(self, robot: str | None = None, reason: str = "e-stop requested") -> list[str]:
        """Latched emergency stop of one robot (or the fleet with robot=None) until explicitly re-armed."""

        def do() -> list[str]:
            targets = [self.registry.get(robot).name] if robot else self.world.robot_names()
            self.safety.estop(robot, reason)
            for r in targets:
                self.world.emergency_stop(r)
            self.events.publish(self.world.time, "estop", targets, reason, fleet=robot is None)
            self._publish()
            return targets

        return self.call(do)

    def rearm(self, robot: str | None = None) -> bool:
        def do() -> bool:
            if robot:
                self.registry.get(robot)
            changed = self.safety.rearm(robot)
            if changed:
                self.events.publish(self.world.time, "rearm", (robot,) if robot else (), "re-armed")
            self._publish()
            return changed

        return self.call(do)

    def acquire_lease(self, client: str, robot: str, ttl: float | None = None) -> dict[str, Any]:
        def do() -> dict[str, Any]:
            self.registry.get(robot)
            if client == AUTONOMY:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"client id '{AUTONOMY}' is reserved")
            self.safety.acquire(client, robot, ttl)
            return {"robot": robot, "client": client}

        return self.call(do)

    def release_lease(self, client: str, robot: str) -> bool:
        return self.call(lambda: self.safety.release(client, robot))

    def release_client(self, client: str, reason: str = "client went away") -> list[str]:
        """Drop all of a client's leases: its robots stop now (the deadman, immediately)."""

        def do() -> list[str]:
            robots = self.safety.release_client(client)
            for r in robots:
                self.world.set_cmd_vel(r, 0.0, 0.0)
            if robots:
                self.events.publish(self.world.time, "client_lost", robots, f"client '{client}': {reason}",
                                    client=client)
            return robots

        return self.call(do)

    def read_sensor(self, robot: str, sensor: str) -> Any:
        """The latest reading: LidarScan, ImuReading, OdometryReading, ContactReading, or a CameraImage
        rendered now (camera/depth), or the ground-truth pose."""
        if sensor not in SENSORS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown sensor '{sensor}'", f"sensors: {', '.join(SENSORS)}")

        def do() -> Any:
            self.registry.get(robot)
            w = self.world
            if sensor == "camera":
                return w.render_camera(robot)
            if sensor == "depth":
                return w.render_camera(robot, which="depth", rgb=False)
            reading = {"lidar": w.latest_scan, "imu": w.latest_imu, "odom": w.latest_odometry,
                       "contact": w.latest_contacts, "pose": w.robot_pose}[sensor](robot)
            if reading is None:
                raise FleetError(ErrorCode.NOT_FOUND, f"no {sensor} reading from '{robot}' yet",
                                 "step or unpause the simulation first")
            return reading

        return self.call(do)

    def render_camera(self, robot: str, which: str = "rgb") -> CameraImage:
        return self.call(lambda: self.world.render_camera(robot, which=which))
