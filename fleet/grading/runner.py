"""run_challenge: grade a contestant on a challenge, run by run, and write the report.

The recipe: load the challenge → resolve it (world file, start, goal) → the optimal path (T_opt) → for each
run: build the service → spawn the robot → drive (a builtin navigator in batch mode, or the contestant's
process over Zenoh in lock-step) → score against ground truth → summary, rubric, report files.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fleet.config import FleetConfig
from fleet.executors import Executor
from fleet.grading.agent_run import drive_agent
from fleet.grading.challenge import Challenge, ResolvedChallenge, load_challenge, resolve
from fleet.grading.course_nav import navigation_rubric
from fleet.grading.episode import Episode
from fleet.grading.report import write_report
from fleet.grading.score import clearances, optimal_path, score_run, summarize
from fleet.grading.types import ChallengeReport, Outcome, RunResult
from fleet.paths import robot_model
from fleet.service import FleetService
from planning import FclWorld, controller_names
from sim.config import dump_yaml
from sim.errors import ErrorCode, FleetError, unknown_name
from sim.robot_spec import RobotSpec

BUILTIN = "builtin:"
ROBOT = "r1"
Progress = Callable[[RunResult], None]


def run_challenge(challenge: Challenge | str | Path, *, agent: str | None = None, controller: str | None = None,
                  runs: int | None = None, out_dir: str | Path | None = None,
                  progress: Progress | None = None, executor: Executor | None = None,
                  live: LiveSettings | None = None) -> ChallengeReport:
    """Grade `agent` (a command, e.g. "python my_nav.py") or `controller` ("builtin:mpc_osqp") on `challenge`
    (a Challenge, a name in configs/challenges or a YAML path). Reports go to `out_dir`. With `executor`
    (fleet.executors) the runs are its jobs (a local pool, a Ray cluster); without, they run here in turn, and
    `live` serves each run in turn to a Foxglove live view, paced at its real-time factor."""
    if live is not None and executor is not None:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "a live view shows runs made here in turn, not a sweep",
                         "drop --live, or the executor options")
    ch = challenge if isinstance(challenge, Challenge) else load_challenge(challenge)
    contestant = _contestant(agent, controller)
    if runs is not None and not 1 <= runs <= 100:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"runs must be in 1..100, got {runs}")
    out = Path(out_dir) if out_dir is not None else Path("challenge_results") / ch.name / _slug(contestant)
    out.mkdir(parents=True, exist_ok=True)
    dump_yaml(ch, out / "challenge.yaml")  # the challenge as run, next to its results
    rc = resolve(ch, out)
    spec = robot_model(ch.robot).spec
    plan = optimal_path(rc.description, rc.start, rc.goal, robot_radius=spec.footprint_radius,
                        planner=ch.optimal_planner)
    fcl_world = FclWorld(rc.description)
    results = []
    n = runs if runs is not None else ch.runs
    if executor is not None:
        from fleet.grading.sweep import run_all

        results = run_all(ch, contestant, n, plan.length, out, executor, progress)
    for k in range(n) if executor is None else ():
        result = _run_once(rc, k, contestant, spec, plan.length, fcl_world, out, live)
        results.append(result)
        if progress is not None:
            progress(result)
    config = {**ch.model_dump(mode="json"), "world_file": str(rc.world_path),
              "start_pose": rc.start.as_tuple(), "goal_pose": rc.goal.as_tuple()}
    report = ChallengeReport(ch.name, contestant, config, results, summarize(results),
                             navigation_rubric(results, contestant, ch.safety_distance))
    write_report(report, out, rc.description, plan.path, rc.goal, spec.footprint_radius)
    return report


def _contestant(agent: str | None, controller: str | None) -> str:
    if (agent is None) == (controller is None):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "give exactly one of agent or controller",
                         'e.g. agent="python my_nav.py" or controller="builtin:mpc_osqp"')
    if controller is not None:
        name = controller.removeprefix(BUILTIN)
        if name not in controller_names():
            raise unknown_name("builtin controller", name, [BUILTIN + n for n in controller_names()],
                               ErrorCode.INVALID_ARGUMENT)
        return BUILTIN + name
    assert agent is not None
    if not agent.strip():
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "the agent command is empty", 'e.g. "python my_nav.py"')
    return agent


@dataclass(frozen=True)
class LiveSettings:
    """A Foxglove live view of a challenge's runs: the WebSocket port and the real-time factor to hold."""

    port: int = 8765
    speed: float = 1.0


def _slug(contestant: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", contestant.replace(BUILTIN, "builtin_"))[:60].strip("_")


def _run_once(rc: ResolvedChallenge, k: int, contestant: str, spec: RobotSpec, optimal_length: float,
              fcl_world: FclWorld, out: Path, live: LiveSettings | None = None) -> RunResult:
    ch = rc.challenge
    seed = ch.seed + k
    builtin = contestant.startswith(BUILTIN)
    nav = navigation_settings(ch, contestant)
    svc = FleetService(FleetConfig(world=str(rc.world_path), physics_hz=ch.physics_hz, control_hz=ch.control_hz,
                                   seed=seed, fidelity=ch.fidelity, robot_model=ch.robot, navigation=nav))
    if ch.map_source == "sensors":  # the graded robot must not read the world file, nor may its agent
        svc.withhold_prior_map(f"challenge {ch.name}")
    ep = Episode(svc, ROBOT, rc.goal, success_radius=ch.success_radius, time_limit=ch.time_limit,
                 collision_rule=ch.collision)
    wall0 = time.perf_counter()
    log = ""
    view = None
    try:
        if live is not None:
            from fleet.live_view import LiveView

            view = LiveView(port=live.port).attach(svc)
        svc.spawn_robot(ROBOT, rc.start)
        if builtin:
            _drive_builtin(svc, ep, ch.agent.wall_limit_s, pace=live.speed if live is not None else None)
        else:
            log = drive_agent(svc, ep, contestant, out / f"run_{k}_agent.log", ch.agent)
    finally:
        ep.close()
        if view is not None:
            view.close()
        svc.close()
    assert ep.outcome is not None
    traj = ep.trajectory()
    success = ep.outcome is Outcome.SUCCEEDED
    score = score_run(traj, success=success, t=ep.t_goal if ep.t_goal is not None else ep.elapsed,
                      optimal_length=optimal_length, v_max=spec.limits.max_linear,
                      collision_times=ep.collision_times, clearance=clearances(traj, fcl_world, spec.footprint),
                      safety_distance=ch.safety_distance, goal=rc.goal, success_radius=ch.success_radius)
    return RunResult(k, seed, ep.outcome, ep.reason, score, traj, time.perf_counter() - wall0, log)


def navigation_settings(ch: Challenge, contestant: str) -> dict[str, object]:
    """The service's `navigation` settings for a run: a builtin's controller and the challenge's map source
    (an agent brings its own navigation)."""
    if not contestant.startswith(BUILTIN):
        return {}
    return {"controller": {"type": contestant.removeprefix(BUILTIN)}, "map_source": ch.map_source}


def _drive_builtin(svc: FleetService, ep: Episode, wall_limit_s: float, pace: float | None = None) -> None:
    """fleetnav's own navigator (plan → track → replan → recover), stepped in batch mode one tick at a time;
    `pace` (a real-time factor) holds the run to the wall clock for a live view."""
    steps = max(1, round(svc.config.physics_hz / svc.config.control_hz))
    task = svc.navigate(ROBOT, ep.goal)
    ep.start()
    wall0, sim0 = time.perf_counter(), svc.sim_time
    deadline = time.monotonic() + wall_limit_s
    while not ep.done.is_set():
        svc.step(steps)
        if pace:
            time.sleep(max(0.0, (svc.sim_time - sim0) / pace - (time.perf_counter() - wall0)))
        state = svc.tasks.get(task["id"])
        if state.state.value in ("failed", "canceled"):
            ep.finish(Outcome.NAVIGATION_FAILED, f"the navigator gave up: {state.reason}")
        elif time.monotonic() > deadline:
            ep.finish(Outcome.WALL_TIMEOUT, f"the run took more than {wall_limit_s:g} s of wall time")
