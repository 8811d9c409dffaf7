"""Setting a mission up on a FleetService: the service config, the robots, and the timeline of everything
the mission does at a sim time (submit tasks, allocate, start behaviours, fire scripted events).

Each timeline entry runs at the first control tick at or after its time; entries at one time run in file
order (robots first, then tasks, allocation, behaviours, events), so a run is reproducible.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fleet.config import FleetConfig
from fleet.missions.events import EVENTS
from fleet.missions.schema import Mission
from fleet.missions.types import RunData, TaskRecord
from sim.errors import FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService


@dataclass(order=True)
class Scheduled:
    at: float
    order: int
    label: str
    run: Callable[[], str]


def fleet_config(m: Mission) -> FleetConfig:
    """The service config the mission asks for (world resolved by the loader, seed already overridden)."""
    return FleetConfig(world=m.world, physics_hz=m.physics.physics_hz, control_hz=m.physics.control_hz,
                       seed=m.seed, fidelity=m.physics.fidelity, safety=m.safety, battery=m.battery,
                       navigation=m.navigation, avoidance=m.avoidance, costmap_resolution=m.costmap_resolution)


def spawn_robots(m: Mission, svc: FleetService, data: RunData) -> None:
    if m.physics.gravity is not None or m.physics.solver_iterations is not None:
        svc.set_physics_properties(**{k: v for k, v in (("gravity", m.physics.gravity),
                                                        ("solver_iterations", m.physics.solver_iterations))
                                      if v is not None})
    spawns = {sp.name: sp.pose for sp in svc.world.description.spawn_points}
    for model in {r.model for r in m.robots} | {f.model for f in m.fleets if f.model}:
        if Path(model).is_absolute():  # the loader made file models absolute; the mission file is trusted
            svc.workspace.trust(Path(model).parent)
    for r in m.robots:
        pose = r.pose.pose() if r.pose is not None else spawns[r.spawn or ""]
        svc.spawn_robot(r.name, pose, model=r.model, fidelity=r.fidelity)
        if r.battery is not None:
            svc.set_battery(r.name, r.battery)
    for f in m.fleets:
        svc.spawn_fleet(f.count, f.formation, f.centre.pose() if f.centre else None, f.spacing, f.prefix,
                        radius=f.radius, model=f.model, fidelity=f.fidelity)
    for name in svc.world.robot_names():
        spec = svc.world.robot_spec(name)
        data.radius[name], data.v_max[name] = spec.footprint_radius, spec.limits.max_linear
    if m.traffic is not None:  # before any task: traffic_go tasks join this layer
        from fleet.traffic import ensure_traffic

        settings = m.traffic.model_dump(exclude={"type"})
        svc.call(lambda: ensure_traffic(svc, settings))


def timeline(m: Mission, svc: FleetService, data: RunData) -> list[Scheduled]:
    """Everything the mission does after spawning, sorted by (time, file order)."""
    items: list[Scheduled] = []
    nav = {r.name: r.navigation for r in m.robots if r.navigation}
    keys = m.task_keys()
    for i, t in enumerate(m.tasks):
        params = ({"navigation": nav[t.robot]} if t.robot in nav else {}) | t.params
        items.append(Scheduled(t.at, len(items), f"task {keys[i]}",
                               _submit(svc, data, keys[i], t.robot, t.type, params, t.priority)))
    if m.allocation is not None:
        items.append(Scheduled(m.allocation.at, len(items), "allocation", lambda: _allocate(m, svc, data)))
    for key, b in zip(m.behaviour_keys(), m.behaviours, strict=True):
        items.append(Scheduled(b.at, len(items), f"behaviour {key}", _behaviour(svc, data, key, b.type, b.robots,
                                                                                b.params)))
    for i, e in enumerate(m.events):
        fn = EVENTS.get(e.type)
        items.append(Scheduled(e.at, len(items), f"event {i} {e.type}",
                               lambda e=e, fn=fn: fn(e, svc, data)))  # type: ignore[misc]
    return sorted(items)


def _submit(svc: FleetService, data: RunData, key: str, robot: str, type_name: str, params: dict[str, Any],
            priority: int) -> Callable[[], str]:
    def run() -> str:
        rec = data.tasks[key] = TaskRecord(key, robot, type_name, "", dict(params), state="failed")
        try:
            out = svc.submit_task(type_name, robot, params, priority=priority)
        except FleetError as exc:  # the run goes on; the task stays failed with the reason
            rec.reason = f"refused: {exc.message}"
            raise
        data.tasks[key].task_id, data.tasks[key].state = out["id"], out["state"]
        return f"{type_name} '{key}' submitted to {robot}"

    return run


def _allocate(m: Mission, svc: FleetService, data: RunData) -> str:
    a = m.allocation
    assert a is not None
    specs = [t.model_dump(exclude_none=True) for t in a.tasks]
    for t in a.tasks:  # failed unless the allocation places it
        data.tasks[t.id] = TaskRecord(t.id, "", t.type, "", dict(t.params), state="failed",
                                      reason="not allocated")
    result = svc.assign_tasks(specs, a.robots, a.method, **a.options)
    for asg in result.assignments:
        rec = data.tasks[asg.request]
        rec.robot, rec.task_id, rec.state, rec.reason = asg.robot, asg.task_ids[-1], "queued", ""
    for inf in result.infeasible:
        data.tasks[inf.request].reason = f"infeasible: {inf.reason}"
    return (f"{len(result.assignments)} tasks allocated by {result.method} (travel {result.travel_m:.1f} m), "
            f"{len(result.infeasible)} infeasible")


def _behaviour(svc: FleetService, data: RunData, key: str, type_name: str, robots: list[str] | None,
               params: dict[str, Any]) -> Callable[[], str]:
    def run() -> str:
        out = svc.start_behaviour(type_name, robots, params)
        data.behaviours[key] = {"id": out["id"], "type": type_name, "robots": out["robots"]}
        return f"behaviour {type_name} '{key}' on {', '.join(out['robots'])}"

    return run


def refresh_tasks(svc: FleetService, data: RunData) -> None:
    """Copy each mission task's state from the task manager (on the sim thread; batch mode calls it inline)."""
    for rec in data.tasks.values():
        if not rec.task_id:
            continue
        task = svc.tasks.tasks.get(rec.task_id)
        if task is None:
            continue
        d = task.to_dict()
        rec.state, rec.reason, rec.started, rec.finished = d["state"], d["reason"], d["started"], d["finished"]
        rec.progress = d["progress"]


def refresh_behaviours(svc: FleetService, data: RunData) -> None:
    for b in data.behaviours.values():
        status = svc.behaviours.running[b["id"]].to_dict()
        b.update(state=status["state"], metrics=status["metrics"], initial_metrics=status["initial_metrics"],
                 converged=status["converged"], convergence_time_s=status["convergence_time_s"])
