"""FleetService operations on the simulation and the world's models: clock, snapshots, files, physics."""

from __future__ import annotations

import time
from typing import Any

from fleet.core import ServiceCore
from fleet.paths import CONFIGS
from sim import ClockMode, FleetError, ModelState, Pose3D
from sim.errors import ErrorCode


class SimOps(ServiceCore):
    """Mixed into FleetService."""

    # ---- clock ------------------------------------------------------------------------------------------

    def pause(self) -> None:
        self.call(lambda: self.clock.set_mode(ClockMode.PAUSED, self.world))

    def resume(self, speed: float | None = None) -> None:
        """Run in real time × speed (service mode); in batch mode use advance()/step()."""
        self.call(lambda: self.clock.set_mode(ClockMode.REALTIME, self.world, speed))

    def run_fast(self) -> None:
        self.call(lambda: self.clock.set_mode(ClockMode.FAST, self.world))

    def set_speed(self, speed: float) -> None:
        self.call(lambda: self.clock.set_mode(self.clock.mode, self.world, speed))

    def status(self) -> dict[str, Any]:
        snap = self.snapshot
        return {**snap.summary(), "physics_hz": self.world.physics_hz, "control_hz": self.config.control_hz,
                "speed": self.clock.speed, "threaded": self.threaded, "step_count": snap.step_count,
                "world_file": str(self.world_path), "models": len(self.world.models.names())}

    def performance(self, steps: int = 100) -> dict[str, Any]:
        """Measure the step cost now (runs `steps` steps on the sim thread) and where it goes."""
        if not 1 <= steps <= 10_000:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"steps must be in [1, 10000], got {steps}")

        def do() -> dict[str, Any]:
            import cProfile
            import pstats

            prof = cProfile.Profile()
            t0, sim0 = time.perf_counter(), self.world.time
            prof.enable()
            self._step(steps)
            prof.disable()
            wall = time.perf_counter() - t0
            stats = pstats.Stats(prof)
            top = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:8]  # type: ignore[attr-defined]
            return {"steps": steps, "wall_s": wall, "step_ms": 1e3 * wall / steps,
                    "real_time_factor": (self.world.time - sim0) / wall if wall > 0 else None,
                    "robots": len(self.world.robot_names()),
                    "hotspots": [{"function": f"{k[2]} ({k[0].split('/')[-1]}:{k[1]})", "self_s": round(v[2], 5)}
                                 for k, v in top]}

        return self.call(do)

    # ---- snapshots ----------------------------------------------------------------------------------------

    def save_snapshot(self, name: str) -> dict[str, Any]:
        def do() -> dict[str, Any]:
            self._snapshots[name] = (self.world.snapshot(), self.battery.soc.copy())
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
        path = str(self.workspace.resolve(file)) if file is not None else None

        def do() -> list[str]:
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
        def do() -> ModelState:
            st = self.world.set_model_state(name, pose=pose, linear=linear, angular=angular)
            if pose is not None and not self.registry.has(name):
                self._invalidate_maps()
            return st

        return self.call(do)

    def apply_force(self, name: str, force: tuple[float, float, float],
                    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.call(lambda: self.world.apply_force(name, force, torque))

    def physics_properties(self) -> dict[str, Any]:
        return self.call(self.world.physics_properties)

    def set_physics_properties(self, **kw: Any) -> dict[str, Any]:
        return self.call(lambda: self.world.set_physics_properties(**kw))

    def _invalidate_maps(self) -> None:
        """The static world changed: rasterise again on next use (robots' costmaps are rebuilt)."""
        self._static_grid = None
        self._costmaps.clear()
