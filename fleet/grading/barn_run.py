"""One BARN run in the sim: the grader (BarnClock on ground truth, the world's true shapes for clearance) and
the navigator (a builtin, fed only the robot's own scans unless map_source says otherwise) share one parsed
world, so both see the same obstacles and bounds.

`run_barn_job` is a top-level function of a picklable `BarnJob`, so any process pool or executor can run it.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fleet.grading.barn import BARN_GOAL, BARN_START, V_OPT, BarnClock, barn_metric, optimal_length
from planning.collision import FclWorld
from planning.costmap import LayeredCostmap
from planning.nav_types import NavState
from planning.navigator import NavigatorConfig, make_navigator
from planning.sensor_nav import SensorNavConfig, SensorNavigator
from sim.errors import ErrorCode, FleetError
from sim.robot_spec import RobotSpec
from sim.types import LidarScan, Pose2D, WorldDescription
from sim.world import World

# footprint_dwa: the sensor navigator (map_source decides what it knows); navigator: planning.Navigator, the
# pre-existing stack (circumscribed-disc inflation on the prior map, guided Theta* + MPC), kept as the baseline.
BUILTINS = ("footprint_dwa", "navigator")
MAX_SIM_S = 120.0  # BARN's 100 s after the start-move, plus room for a robot that never starts


@dataclass(frozen=True)
class BarnJob:
    world_id: int
    world: str
    path: str
    spec: dict[str, Any]  # RobotSpec.model_dump(): plain data, picklable
    controller: str = "footprint_dwa"
    nav: dict[str, Any] = field(default_factory=dict)  # SensorNavConfig overrides (map_source, margin, …)
    run: int = 0
    seed: int = 0
    control_hz: float = 10.0
    physics_hz: float = 50.0
    agent: str = ""  # an external agent command (placeholders as `fleetnav challenge run --agent`) instead
    agent_limits: dict[str, Any] = field(default_factory=dict)  # AgentSection overrides (startup/tick/wall s)


def check_controller(name: str) -> str:
    """`builtin:NAME` → NAME, or a clear error listing the builtins."""
    kind, _, rest = name.partition(":")
    if kind != "builtin" or rest not in BUILTINS:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown controller '{name}'",
                         f"use one of: {', '.join('builtin:' + b for b in BUILTINS)}")
    return rest


def run_barn_job(job: BarnJob) -> dict[str, Any]:
    """Run one world once; returns the results.jsonl row. Never raises for a navigation failure (the row
    says what happened); setup errors (bad world file) come back as outcome 'error' with the message."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    try:
        if job.agent:
            from fleet.grading.barn_agent import run_agent_job  # it imports this module

            row = run_agent_job(job)
        else:
            row = _run(job)
    except FleetError as exc:
        row = result_row(job, outcome="error", reason=f"{exc.code.value}: {exc.message}")
    row["wall_s"] = round(time.perf_counter() - wall0, 3)
    row["cpu_s"] = round(time.process_time() - cpu0, 3)  # this process's CPU time: wall time on an idle core
    return row


def error_row(job: BarnJob, reason: str) -> dict[str, Any]:
    """The row of a run that produced none (it raised, timed out or its worker was lost)."""
    return result_row(job, outcome="error", reason=reason)


def result_row(job: BarnJob, **kw: Any) -> dict[str, Any]:
    base: dict[str, Any] = {"world_id": job.world_id, "run": job.run, "success": False, "collided": False,
                            "timed_out": False, "time_s": math.nan, "distance_to_goal": math.nan,
                            "path_length": 0.0, "min_clearance": math.nan, "barn_metric": 0.0, "t_opt": math.nan,
                            "optimal_length": math.nan, "outcome": "", "reason": "",
                            "map_source": "agent" if job.agent else "prior" if job.controller == "navigator"
                            else job.nav.get("map_source", "sensors"),
                            "controller": "agent" if job.agent else job.controller, "robot": job.spec.get("name", "")}
    base.update(kw)
    return base


def _run(job: BarnJob) -> dict[str, Any]:
    spec = RobotSpec.model_validate(job.spec)
    cfg = SensorNavConfig.model_validate(job.nav)
    l_opt = optimal_length(Path(job.path))
    t_opt = l_opt / V_OPT
    world = World.from_sdf(job.world, fidelity="kinematic", seed=job.seed, physics_hz=job.physics_hz)
    try:
        desc = world.description
        fcl_world = FclWorld(desc)
        world.spawn_robot("r1", BARN_START, spec)
        world.run_for(0.2)  # a first scan exists before the first decision
        control_dt = 1.0 / job.control_hz
        nav = _builtin(job.controller, cfg, spec, desc, control_dt)
        nav.set_goal(BARN_GOAL, world.time, BARN_START)
        clock = BarnClock()
        steps = max(1, round(job.physics_hz / job.control_hz))
        prev = world.robot_pose("r1")
        driven, clearance = 0.0, math.inf
        returns, scans = 0, 0  # lidar returns seen: a lidar mounted above the obstacles sees none
        t_origin = world.time
        while not clock.outcome and world.time - t_origin < MAX_SIM_S:
            pose = world.robot_pose("r1")
            scan = world.latest_scan("r1")
            if scan is not None:
                returns, scans = returns + int(np.isfinite(scan.ranges).sum()), scans + 1
            v, w = nav.tick(world.time, pose, world.robot_twist("r1"), scan)
            if nav.state is NavState.FAILED:
                break
            world.set_cmd_vel("r1", v, w)
            collided = False
            for _ in range(steps):  # collisions are checked every physics step, as Gazebo's contact sensor
                world.step(1)
                collided |= world.robot_in_collision("r1")
            now = world.robot_pose("r1")
            driven += now.distance_to(prev)
            prev = now
            clearance = min(clearance, fcl_world.min_distance(now, spec.footprint))
            clock.update(world.time - t_origin, now, collided)
        final = world.robot_pose("r1")
    finally:
        world.close()
    outcome = clock.outcome or ("nav_failed" if nav.state is NavState.FAILED else "timeout")
    success = outcome == "succeeded"
    t = clock.elapsed
    return result_row(job, success=success, collided=clock.collided, timed_out=outcome == "timeout",
                time_s=round(t, 3), distance_to_goal=round(final.distance_to(BARN_GOAL), 3),
                path_length=round(driven, 3), min_clearance=round(clearance, 4),
                barn_metric=round(barn_metric(success, t, t_opt), 4), t_opt=round(t_opt, 4),
                optimal_length=round(l_opt, 4), outcome=outcome,
                reason=nav.reason if outcome == "nav_failed" else "",
                replans=nav.replans, recoveries=nav.recoveries,
                lidar_returns_per_scan=round(returns / scans, 1) if scans else 0.0)


class _Baseline:
    """planning.Navigator on the world's prior costmap (grown to cover start and goal), the same interface."""

    def __init__(self, spec: RobotSpec, desc: WorldDescription) -> None:
        x0, y0, x1, y1 = desc.bounds(margin=1.0)
        bounds = (min(x0, BARN_START.x, BARN_GOAL.x) - 3.0, min(y0, BARN_START.y, BARN_GOAL.y) - 3.0,
                  max(x1, BARN_START.x, BARN_GOAL.x) + 3.0, max(y1, BARN_START.y, BARN_GOAL.y) + 3.0)
        costmap = LayeredCostmap.from_world(desc, robot_radius=spec.footprint_radius, bounds=bounds,
                                            sensor_offset=(spec.mast.x_offset, 0.0))
        self.nav = make_navigator(NavigatorConfig(timeout_s=MAX_SIM_S), costmap=costmap, spec=spec)

    def set_goal(self, goal: Pose2D, now: float, start: Pose2D) -> None:
        self.nav.set_goal(goal, now)

    def tick(self, now: float, pose: Pose2D, twist: tuple[float, float], scan: LidarScan | None) -> tuple[float, float]:
        return self.nav.tick(now, pose, twist, scan)

    @property
    def state(self) -> NavState:
        return self.nav.state

    @property
    def reason(self) -> str:
        return self.nav.status().reason

    @property
    def replans(self) -> int:
        return self.nav.status().replans

    @property
    def recoveries(self) -> int:
        return self.nav.status().recoveries


def _builtin(name: str, cfg: SensorNavConfig, spec: RobotSpec, desc: WorldDescription,
             control_dt: float) -> SensorNavigator | _Baseline:
    if name == "navigator":
        return _Baseline(spec, desc)
    return SensorNavigator(cfg, spec, control_dt=control_dt,
                           prior=desc if cfg.map_source in ("prior", "both") else None)


def job_dict(job: BarnJob) -> dict[str, Any]:
    return asdict(job)
