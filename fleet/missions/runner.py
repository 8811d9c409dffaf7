"""MissionRunner: one mission, one seed, headless and as fast as possible (batch mode: no threads).

`run` is the recipe: write the config → build the service → record → spawn → drive the timeline until
done or the time limit → collect → assert → report. Anything the mission asks for that the service
refuses (a FleetError: a bad task parameter, an unreachable goal at submit) is a failed `setup` assertion
in the report, never an exception out of the runner.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from fleet.missions.agents import AgentSession
from fleet.missions.assertions import ASSERTIONS
from fleet.missions.metrics import MetricsCollector
from fleet.missions.plot import save_plot
from fleet.missions.report import build_report, write_reports
from fleet.missions.schema import Mission
from fleet.missions.setup import Scheduled, fleet_config, refresh_behaviours, refresh_tasks, spawn_robots, timeline
from fleet.missions.slam_probe import SlamProbe
from fleet.missions.types import AssertionResult, RunData, RunOutcome
from fleet.recording import McapRecorder, NullRecorder, Recorder
from fleet.service import FleetService
from fleet.types import TaskState
from planning import LayeredCostmap, get_planner
from sim.clock import ClockMode
from sim.errors import FleetError
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.live_view import LiveView

Progress = Callable[[float, float], None]  # (sim time, time limit)
DONE = {s.value for s in TaskState if s.done}


class MissionRunner:
    def __init__(self, mission: Mission, out_dir: str | Path, *, source: str = "", record: bool = True,
                 progress: Progress | None = None, live: LiveView | None = None, pace: float | None = None) -> None:
        """`pace`: real-time factor to hold (for a live view); None runs as fast as possible."""
        self.mission, self.out = mission, Path(out_dir)
        self.source = source
        self.progress = progress or (lambda t, limit: None)
        self.pace = pace
        rec = mission.recording
        self.recorder: Recorder = NullRecorder() if live is None else live
        if record and rec.enabled:  # the live view, if any, serves the recording's own channels
            self.recorder = McapRecorder(self.out / "recording.mcap", scans=rec.scans, markers_hz=rec.markers_hz,
                                         camera_robot=rec.camera_robot, camera_hz=rec.camera_hz, live=live)

    def run(self) -> RunOutcome:
        wall0 = self._wall0 = time.perf_counter()
        self._next_report = 0.0
        config_text = self._write_config()
        svc = FleetService(fleet_config(self.mission))
        data = RunData(time_limit=self.mission.time_limit, service=svc)
        try:
            metrics, probes = self._spawn(svc, data)
            self.recorder.attach(svc, config_text, self.mission.seed)
            self._drive(svc, data, timeline(self.mission, svc, data))
            channels = self.recorder.close()
            self._collect(svc, data, metrics, probes)
            results = self._evaluate(data)
        finally:
            self.recorder.close()
            svc.close()
        return self._report(data, results, channels, time.perf_counter() - wall0)

    # ---- steps -------------------------------------------------------------------------------------------

    def _write_config(self) -> str:
        """The mission actually run (seed and overrides applied, world resolved), next to the outputs."""
        self.out.mkdir(parents=True, exist_ok=True)
        text = yaml.safe_dump(self.mission.model_dump(mode="json"), sort_keys=False)
        (self.out / "mission.yaml").write_text(text, encoding="utf-8")
        return text

    def _spawn(self, svc: FleetService, data: RunData) -> tuple[MetricsCollector, list[SlamProbe]]:
        try:
            spawn_robots(self.mission, svc, data)
        except FleetError as exc:
            data.setup_errors.append(f"spawn: {exc}")
        probes = [SlamProbe(svc, s.robot, s.config) for s in self.mission.slam if s.robot in svc.world.robot_names()]
        data.optimal_length = _optimal_length(svc, data)
        return MetricsCollector(svc, data), probes

    def _drive(self, svc: FleetService, data: RunData, schedule: list[Scheduled]) -> None:
        """Step one control period at a time (batch mode: no threads); or, with external agents, run the world
        on its sim thread behind a Zenoh bridge and check after each tick. Either way the timeline fires and the
        end is decided at control ticks, in sim time."""
        if self.mission.agents is None:
            steps = round(self.mission.physics.physics_hz / self.mission.physics.control_hz)
            while not self._tick(svc, data, schedule):
                svc.step(steps)
        else:
            self._drive_with_agents(svc, data, schedule)
        data.end_time = round(svc.world.time, 6)
        self.progress(data.end_time, self.mission.time_limit)

    def _tick(self, svc: FleetService, data: RunData, schedule: list[Scheduled], agents_done: bool = True) -> bool:
        """At a control tick: fire what is due, refresh task states, report progress; True when the run ends."""
        now = svc.world.time
        while schedule and schedule[0].at <= now + 1e-9:
            self._fire(schedule.pop(0), svc, data)
        refresh_tasks(svc, data)
        if now >= self._next_report:
            self.progress(now, self.mission.time_limit)
            self._next_report = now + 1.0
        if self.pace:
            time.sleep(max(0.0, now / self.pace - (time.perf_counter() - self._wall0)))
        if now >= self.mission.time_limit - 1e-9:
            data.ended_because = "time limit"
        elif data.setup_errors and not svc.world.robot_names():
            data.ended_because = "setup failed"
        elif self.mission.end_when == "tasks_done" and not schedule and agents_done and self._all_done(svc, data):
            data.ended_because = "all tasks done"
        return bool(data.ended_because)

    def _drive_with_agents(self, svc: FleetService, data: RunData, schedule: list[Scheduled]) -> None:
        assert self.mission.agents is not None
        mission_dir = Path(self.source).resolve().parent if self.source else Path.cwd()
        session = AgentSession(svc, self.mission.agents, self.out, mission_dir)
        done = threading.Event()

        def on_tick(_: object) -> None:  # sim thread, after each control tick
            if not done.is_set() and self._tick(svc, data, schedule, agents_done=session.finished()):
                svc.clock.set_mode(ClockMode.PAUSED, svc.world)
                done.set()

        try:
            session.start()
            session.wait_joined()
            if not svc.call(lambda: self._tick(svc, data, schedule, session.finished())):  # due at t = 0
                svc.tick_listeners.append(on_tick)
                svc.run_fast()
                deadline = time.monotonic() + self.mission.agents.wall_limit_s
                while not done.wait(0.05) and not session.crashed():
                    if time.monotonic() > deadline:
                        data.setup_errors.append(f"wall limit {self.mission.agents.wall_limit_s:g} s reached")
                        data.ended_because = "wall limit"
                        break
        except FleetError as exc:
            data.setup_errors.append(f"agents: {exc}")
        finally:
            data.ended_because = data.ended_because or "agent failed"
            data.setup_errors += session.crashed()
            data.agents = session.stop()
            if on_tick in svc.tick_listeners:
                svc.tick_listeners.remove(on_tick)

    def _fire(self, item: Scheduled, svc: FleetService, data: RunData) -> None:
        t = round(svc.world.time, 6)
        try:
            data.scripted.append({"t": t, "what": item.label, "result": item.run()})
        except FleetError as exc:
            data.setup_errors.append(f"{item.label} at t={t:g} s: {exc}")
            data.scripted.append({"t": t, "what": item.label, "result": f"refused: {exc.message}"})

    def _all_done(self, svc: FleetService, data: RunData) -> bool:
        """Every task ended and no behaviour runs (a mission of agents alone: once they have all exited)."""
        tasks_done = all(r.state in DONE for r in data.tasks.values())
        behaving = any(b.state == "running" for b in svc.behaviours.running.values())
        return tasks_done and not behaving and bool(data.tasks or data.setup_errors or self.mission.agents)

    def _collect(self, svc: FleetService, data: RunData, metrics: MetricsCollector, probes: list[SlamProbe]) -> None:
        refresh_tasks(svc, data)
        refresh_behaviours(svc, data)
        metrics.finish()
        data.grid = svc.static_grid()
        for p in probes:
            data.slam[p.robot] = p.result(self.out)

    def _evaluate(self, data: RunData) -> list[AssertionResult]:
        results = [AssertionResult("setup", "setup", False, float(len(data.setup_errors)), "0 errors",
                                   "; ".join(data.setup_errors))] if data.setup_errors else []
        for name, a in zip(self.mission.assertion_names(), self.mission.assertions, strict=True):
            results.append(ASSERTIONS.get(a.type)(a, data, name))
        return results

    def _report(self, data: RunData, results: list[AssertionResult], channels: dict[str, int],
                wall_s: float) -> RunOutcome:
        recorded = isinstance(self.recorder, McapRecorder)
        report = build_report(self.mission, self.source, data, results, channels, wall_s, recorded)
        write_reports(report, self.out)
        save_plot(data, self.out / "trajectories.png")
        data.service = None
        return RunOutcome(self.mission.name, self.source, self.mission.seed, report["passed"], report, self.out, wall_s)


def _optimal_length(svc: FleetService, data: RunData) -> Callable[[str, Pose2D, Pose2D], float]:
    """Theta* on the static costmap inflated by the robot's radius: the T_opt path of the BARN score."""
    planner = get_planner(type="theta_star")
    cache: dict[float, LayeredCostmap] = {}

    def length(robot: str, start: Pose2D, goal: Pose2D) -> float:
        r = data.radius.get(robot, 0.25)
        if r not in cache:
            cache[r] = LayeredCostmap(svc.static_grid(), robot_radius=r)
        try:
            return planner.plan(start, goal, cache[r]).length
        except FleetError:
            return math.nan

    return length
