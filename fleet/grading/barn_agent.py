"""One BARN run driven by an external agent process over Zenoh in lock-step (`fleetnav barn run --agent CMD`).

The same machinery as `fleetnav challenge run --agent` (fleet.grading.agent_run: bridge on a free loopback
port, the process started with the same placeholders, lock-step, crash/hang/no-show become graded failures),
on the BARN world with the BARN start and goal. The score is BARN's, from the recorded ground-truth
trajectory: BarnClock replays it tick by tick (T from 0.1 m off the start to within 1 m of the goal, 100 s
limit, any contact fails), so an agent and a builtin are judged by exactly the same rules.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from fleet.grading.barn import BARN_GOAL, BARN_START, SUCCESS_RADIUS, V_OPT, BarnClock, barn_metric, optimal_length
from fleet.grading.barn_run import MAX_SIM_S, BarnJob, result_row
from fleet.grading.challenge import AgentSection
from fleet.grading.episode import Episode
from fleet.grading.score import clearances
from fleet.grading.types import Outcome
from fleet.safety import SafetyConfig
from planning.collision import FclWorld
from sim.config import dump_yaml
from sim.robot_spec import RobotSpec
from sim.sdf_parser import parse_sdf
from sim.types import Pose2D

ROBOT = "r1"
LOG_TAIL_LINES = 8  # of the agent's output, in the row of a run the agent lost (its traceback)


def run_agent_job(job: BarnJob) -> dict[str, Any]:
    """The results row of `job` (its `agent` command drives the robot)."""
    from fleet.config import FleetConfig
    from fleet.grading.agent_run import drive_agent
    from fleet.service import FleetService

    spec = RobotSpec.model_validate(job.spec)
    l_opt = optimal_length(Path(job.path))
    t_opt = l_opt / V_OPT
    limits = AgentSection.model_validate(job.agent_limits)
    with tempfile.TemporaryDirectory(prefix="fleetnav-barn-agent-") as tmp:
        robot_yaml = Path(tmp) / f"{spec.name}.yaml"
        dump_yaml(spec, robot_yaml)  # the job carries the model as data: workers need no robot folder
        svc = FleetService(FleetConfig(world=job.world, physics_hz=job.physics_hz, control_hz=job.control_hz,
                                       seed=job.seed, fidelity="kinematic", robot_model=str(robot_yaml),
                                       safety=SafetyConfig(geofence=_fence(Path(job.world)))))
        if job.nav.get("map_source", "sensors") == "sensors":  # BARN's rule: no prior map for the agent either
            svc.withhold_prior_map(f"BARN world {job.world_id}")
        ep = Episode(svc, ROBOT, BARN_GOAL, success_radius=SUCCESS_RADIUS, time_limit=MAX_SIM_S,
                     collision_rule="end")
        try:
            fcl_world = FclWorld(svc.world.description)
            svc.spawn_robot(ROBOT, BARN_START)
            log = drive_agent(svc, ep, job.agent, Path(tmp) / "agent.log", limits)
        finally:
            ep.close()
            svc.close()
    assert ep.outcome is not None
    traj = ep.trajectory()
    clock = _replay(traj, ep.collision_times)
    agent_lost = ep.outcome not in (Outcome.SUCCEEDED, Outcome.COLLISION, Outcome.TIMEOUT)
    outcome = clock.outcome or (ep.outcome.value if agent_lost else "timeout")
    success = outcome == "succeeded"
    final = Pose2D(*(float(v) for v in traj[-1, 1:4])) if len(traj) else BARN_START
    driven = float(np.hypot(*np.diff(traj[:, 1:3], axis=0).T).sum()) if len(traj) > 1 else 0.0
    clear = clearances(traj, fcl_world, spec.footprint) if len(traj) else np.array([math.nan])
    extra: dict[str, Any] = {"agent_outcome": ep.outcome.value}
    if not success:
        extra["agent_log"] = "\n".join(log.splitlines()[-LOG_TAIL_LINES:])
    return result_row(job, success=success, collided=clock.collided, timed_out=outcome == "timeout",
                      time_s=round(clock.elapsed, 3), distance_to_goal=round(final.distance_to(BARN_GOAL), 3),
                      path_length=round(driven, 3), min_clearance=round(float(np.min(clear)), 4),
                      barn_metric=round(barn_metric(success, clock.elapsed, t_opt), 4), t_opt=round(t_opt, 4),
                      optimal_length=round(l_opt, 4), outcome=outcome,
                      reason="" if success else ep.reason, **extra)


def _fence(world: Path) -> tuple[float, float, float, float]:
    """The geofence: the obstacles, start and goal + 3 m, the area the builtins plan in (barn_run._Baseline).
    The default fence (obstacles + 0.5 m) would stop the robot short of BARN's goal beyond them."""
    x0, y0, x1, y1 = parse_sdf(world).bounds(margin=1.0)
    return (min(x0, BARN_START.x, BARN_GOAL.x) - 3.0, min(y0, BARN_START.y, BARN_GOAL.y) - 3.0,
            max(x1, BARN_START.x, BARN_GOAL.x) + 3.0, max(y1, BARN_START.y, BARN_GOAL.y) + 3.0)


def _replay(traj: np.ndarray, collision_times: list[float]) -> BarnClock:
    """BARN's clock over the recorded rows (t, x, y, yaw, …): a row is in collision if a contact happened since
    the previous row (contacts are caught at physics rate, rows come at control rate)."""
    clock = BarnClock()
    hits = sorted(collision_times)
    prev_t = -math.inf
    for t, x, y, yaw in traj[:, :4]:
        hit = any(prev_t < c <= t + 1e-9 for c in hits)
        clock.update(float(t), Pose2D(float(x), float(y), float(yaw)), hit)
        prev_t = float(t)
        if clock.outcome:
            break
    return clock
