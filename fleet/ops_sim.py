"""FleetService operations on the simulation and the world's models: clock, snapshots, files, physics."""

from __future__ import annotations

import contextlib
import time
from typing import TYPE_CHECKING, Any, cast

from fleet import validation
from fleet.core import ServiceCore
from fleet.paths import CONFIGS
from fleet.supervision import CMD_BUDGET_S
from sim import ClockMode, FleetError, ModelState, Pose3D
from sim.errors import ErrorCode
from sim.read_policy import policy as read_policy

if TYPE_CHECKING:
    from fleet.service import FleetService


class SimOps(ServiceCore):
    """Mixed into FleetService."""

    # ---- clock ------------------------------------------------------------------------------------------

    def pause(self) -> None:
        self.call(lambda: self.clock.set_mode(ClockMode.PAUSED, self.world))

    def resume(self, speed: float | None = None) -> None:
        """Run in real time × speed (service mode); in batch mode use advance()/step()."""
        if speed is not None:
            validation.speed(speed)
        self.call(lambda: self.clock.set_mode(ClockMode.REALTIME, self.world, speed))

    def run_fast(self) -> None:
        self.call(lambda: self.clock.set_mode(ClockMode.FAST, self.world))

    def set_speed(self, speed: float) -> None:
        validation.speed(speed)
        self.call(lambda: self.clock.set_mode(self.clock.mode, self.world, speed))

    def status(self) -> dict[str, Any]:
        snap = self.snapshot
        return {**snap.summary(), "physics_hz": self.world.physics_hz, "control_hz": self.config.control_hz,
                "speed": self.clock.speed, "threaded": self.threaded, "step_count": snap.step_count,
                "world_file": str(self.world_path), "models": len(self.world.models.names())}

    def performance(self, steps: int = 100) -> dict[str, Any]:
        """Measure the step cost now and where it goes, without changing the world: `steps` steps run under a
        profiler, then the world (time, poses, RNG, sensors) and batteries go back to where they were. With
        tasks running only physics is profiled, so no task sees the detour."""
        validation.count("steps", steps, 10_000, 1)

        def do() -> dict[str, Any]:
            import cProfile
            import pstats

            saved, soc = self.world.snapshot(), self.battery.soc.copy()
            physics_only = self.control.active_count() > 0
            prof = cProfile.Profile()
            t0, sim0 = time.perf_counter(), self.world.time
            try:
                prof.enable()
                if physics_only:
                    for _ in range(steps):
                        self.world.step()
                else:
                    self._step(steps)
                prof.disable()
                wall = time.perf_counter() - t0
                rtf = (self.world.time - sim0) / wall if wall > 0 else None
            finally:
                prof.disable()
                self.world.restore(saved)
                self.battery.soc = soc
                self.repace()
                self._publish()
            stats = pstats.Stats(prof)
            top = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:8]  # type: ignore[attr-defined]
            return {"steps": steps, "wall_s": wall, "step_ms": 1e3 * wall / steps, "real_time_factor": rtf,
                    "robots": len(self.world.robot_names()), "scope": "physics" if physics_only else "physics+control",
                    "hotspots": [{"function": f"{k[2]} ({k[0].split('/')[-1]}:{k[1]})", "self_s": round(v[2], 5)}
                                 for k, v in top]}

        return self.call(do)

    # ---- snapshots ----------------------------------------------------------------------------------------

    def save_snapshot(self, name: str) -> dict[str, Any]:
        def do() -> dict[str, Any]:
            self._snapshots[name] = (self.world.snapshot(), self.battery.soc.copy())
            self._last_snapshot = name
            return {"name": name, "time": self.world.time, "robots": self.world.robot_names()}

        return self.call(do)

    def restore_snapshot(self, name: str) -> dict[str, Any]:
        """Exact restore of the world (poses, velocities, sensors, time, RNG) and batteries; running tasks are
        canceled because a navigator's plan belongs to the timeline that was left."""

        def do() -> dict[str, Any]:
            if name not in self._snapshots:
                raise FleetError(ErrorCode.NOT_FOUND, f"no snapshot '{name}'",
                                 f"snapshots: {', '.join(self._snapshots) or 'none'}")
            snap, soc = self._snapshots[name]
            self.world.restore(snap)
            self.control.cancel_all(f"snapshot '{name}' restored")
            self.battery.soc = soc.copy()
            self.repace()
            self._publish()
            self.events.publish(self.world.time, "snapshot_restored", message=name)
            return {"name": name, "time": self.world.time}

        return self.call(do)

    def list_snapshots(self) -> list[dict[str, Any]]:
        return self.call(lambda: [{"name": n, "time": s.step_count * self.world.dt, "robots": s.robot_names}
                                  for n, (s, _) in self._snapshots.items()])

    # ---- world files and models ----------------------------------------------------------------------------

    @staticmethod
    def list_worlds() -> list[dict[str, str]]:
        return [{"name": f.stem, "path": str(f)} for f in sorted((CONFIGS / "worlds").glob("*.world"))]

    def save_world(self, path: str) -> str:
        target = self.workspace.resolve(path, write=True)

        def do() -> str:
            target.parent.mkdir(parents=True, exist_ok=True)
            self.world.save_sdf(target)
            return str(target)

        return self.call(do)

    def list_models(self) -> list[ModelState]:
        return self.call(self.world.list_models)

    def spawn_model(self, *, name: str | None = None, file: str | None = None, xml: str | None = None,
                    pose: Pose3D | None = None, static: bool | None = None) -> list[str]:
        path = str(self.workspace.read(file, "model file")) if file is not None else None
        if pose is not None:
            validation.pose("pose", pose, self.bounds)

        def do() -> list[str]:
            with read_policy(self.workspace.readable):
                self._check_models(path, xml, pose)
                names = self.world.spawn_model(name=name, file=path, xml=xml, pose=pose, static=static)
            self._invalidate_maps()
            self.events.publish(self.world.time, "model_spawned", message=", ".join(names))
            return names

        return self.call(do)

    def delete_model(self, name: str) -> None:
        def do() -> None:
            if self.registry.has(name):
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{name}' is a robot", "use remove_robot")
            self.world.remove_model(name)
            self._invalidate_maps()
            self.events.publish(self.world.time, "model_deleted", message=name)

        self.call(do)

    def get_model_state(self, name: str) -> ModelState:
        return self.call(lambda: self.world.get_model_state(name))

    def set_model_state(self, name: str, pose: Pose3D | None = None,
                        linear: tuple[float, float, float] | None = None,
                        angular: tuple[float, float, float] | None = None) -> ModelState:
        if pose is not None:
            validation.pose("pose", pose, self.bounds)
        if linear is not None:
            validation.value(validation.VelocityVec, linear, "linear_velocity")
        if angular is not None:
            validation.value(validation.VelocityVec, angular, "angular_velocity")

        def do() -> ModelState:
            st = self.world.set_model_state(name, pose=pose, linear=linear, angular=angular)
            if pose is not None and not self.registry.has(name):
                self._invalidate_maps()
            return st

        return self.call(do)

    def apply_force(self, name: str, force: tuple[float, float, float],
                    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        validation.value(validation.ForceVec, force, "force")
        validation.value(validation.ForceVec, torque, "torque")
        self.call(lambda: self.world.apply_force(name, force, torque))

    def physics_properties(self) -> dict[str, Any]:
        return self.call(self.world.physics_properties)

    def set_physics_properties(self, **kw: Any) -> dict[str, Any]:
        if kw.get("gravity") is not None:
            validation.value(tuple[validation.Velocity, validation.Velocity, validation.Velocity], kw["gravity"],
                             "gravity")
        return self.call(lambda: self.world.set_physics_properties(**kw))

    def _check_models(self, file: str | None, xml: str | None, pose: Pose3D | None) -> None:
        """Parse what spawn_model was given and check its shapes and placement before PyBullet sees them."""
        from dataclasses import replace
        from pathlib import Path

        from sim.sdf_parser import parse_sdf_string
        from sim.urdf_parser import parse_urdf

        if (file is None) == (xml is None):
            return  # world.spawn_model says which one to give
        text = Path(file).read_text(encoding="utf-8") if file is not None else (xml or "")
        if "<robot" in text[:2000] and "<sdf" not in text[:2000]:
            for link in parse_urdf(text).links.values():
                for i, c in enumerate([*link.collisions, *link.visuals]):
                    validation.geometry(f"link {link.name} shape {i}", c.geometry)
            return
        found = parse_sdf_string(text, source=file or "<xml>").models
        validation.models([replace(m, pose=pose) if pose is not None else m for m in found], self.bounds)

    def _invalidate_maps(self) -> None:
        """The static world changed: rasterise again on next use (robots' costmaps are rebuilt)."""
        self._static_grid = None
        self._costmaps.clear()

    # ---- supervision -----------------------------------------------------------------------------------------

    def sim_health(self) -> dict[str, Any]:
        """Whether the sim thread is alive, what it runs now, and why it died (read without the sim thread)."""
        h = self.health
        if self._thread is not None and not self._thread.is_alive() and h.dead_reason is None:
            self._die("the sim thread exited")
        return {**h.to_dict(), "threaded": self._thread is not None, "sim_time": self.sim_time,
                "last_snapshot": self._last_snapshot}

    def restart(self) -> dict[str, Any]:
        """Bring the world back after the sim thread died (or on demand). When the PyBullet world is intact
        and a snapshot was saved, the last snapshot is restored exactly in it; otherwise the world file is
        loaded again with the robots at their last published poses and charge (sim time 0). Tasks are
        canceled either way; the sim thread starts again if it ran before."""
        from sim import Pose2D

        svc = cast("FleetService", self)
        was_threaded, mode, speed = self._thread is not None, self.clock.mode, self.clock.speed
        if self._thread is not None:
            self._running = False
            self._wake.set()
            self._thread.join(timeout=CMD_BUDGET_S + 5)
            if self._thread.is_alive():
                raise FleetError(ErrorCode.BUSY, "the sim thread is still running a command", "try again shortly")
            self._thread = None
        self.health = type(self.health)(restarts=self.health.restarts + 1)
        source, skipped, latest = "", [], self._last_snapshot
        if latest is not None and latest in self._snapshots:
            snap, soc = self._snapshots[latest]
            try:
                self.control.cancel_all("simulation restarted")
                self.world.restore(snap)
                self.battery.soc = soc.copy()
                source = f"snapshot '{latest}'"
            except Exception as exc:  # a broken world or another robot set: rebuild from the file below
                skipped.append(f"snapshot '{latest}': {str(exc)[:120]}")
        if not source:
            last = self._snapshot
            models = {n: self.registry.get(n).model for n in last.names if self.registry.has(n)}
            snaps = dict(self._snapshots)
            with contextlib.suppress(Exception):  # a broken client is what we are replacing
                self.world.close()
            self._build(str(self.world_path))
            self._snapshots, self._last_snapshot = snaps, latest
            source = "the world file"
            for i, n in enumerate(last.names):
                x, y, yaw = (float(v) for v in last.pose[i])
                try:
                    svc.spawn_robot(n, Pose2D(x, y, yaw), model=models.get(n))
                except FleetError as exc:
                    skipped.append(f"{n}: {exc.message}")
            if last.names:
                source = "the world file and the last published robot poses"
        self.repace()
        self._publish()
        self.events.publish(self.world.time, "sim_restarted", message=f"restarted from {source}")
        if was_threaded:
            self.start(mode, speed)
        return {"restored_from": source, "sim_time": self.sim_time, "robots": self.world.robot_names(),
                "skipped": skipped, "restarts": self.health.restarts}
