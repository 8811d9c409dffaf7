"""FleetService operations for task types beyond go_to, docks and battery, and task allocation."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

from pydantic import ValidationError

from fleet import task_params, validation
from fleet.allocation import (
    METHODS,
    Allocation,
    AllocationOptions,
    Energy,
    EuclideanTravel,
    GridTravel,
    RobotInput,
    TaskRequest,
    allocate,
    make_request,
    parse_spec,
)
from fleet.core import ServiceCore
from fleet.tasks.base import _jsonable
from planning import LayeredCostmap
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.allocation.travel import Travel
    from fleet.service import FleetService

XY = tuple[float, float]


class TaskOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_task_ops(self) -> None:
        """Called from FleetService._build after the task manager exists (docks are loaded by the core)."""
        self._unassigned: dict[str, TaskRequest] = {}
        self._grid_travel: tuple[tuple[float, float, int], GridTravel] | None = None

    def _svc(self) -> FleetService:
        return cast("FleetService", self)

    # ---- task types: each submits a registered type through submit_task ---------------------------------

    def follow_waypoints(self, robot: str, waypoints: Sequence[Pose2D | dict[str, Any]], *, mode: str = "sequence",
                         rounds: int | None = 1, dwell_s: float = 0.0, skip_failed: bool = False,
                         client: str = "default") -> dict[str, Any]:
        validation.count("waypoints", len(waypoints), validation.MAX_WAYPOINTS, 1)
        return self._svc().submit_task("follow_waypoints", robot, {
            "waypoints": list(waypoints), "mode": mode, "rounds": rounds, "dwell_s": dwell_s,
            "skip_failed": skip_failed}, client=client)

    def cover_area(self, robot: str, polygon: Sequence[XY], *, holes: Sequence[Sequence[XY]] = (),
                   tool_width: float = 0.5, overlap: float = 0.1, pattern: str = "boustrophedon",
                   min_coverage_pct: float = 0.0, client: str = "default") -> dict[str, Any]:
        outline = validation.polygon("polygon", polygon, self.bounds)
        validation.coverage(outline, tool_width)
        return self._svc().submit_task("cover_area", robot, {
            "polygon": [list(p) for p in polygon], "holes": [[list(p) for p in h] for h in holes],
            "tool_width": tool_width, "overlap": overlap, "pattern": pattern,
            "min_coverage_pct": min_coverage_pct}, client=client)

    def follow_robot(self, robot: str, target: str, *, distance: float = 1.0, duration: float | None = None,
                     client: str = "default") -> dict[str, Any]:
        return self._svc().submit_task("follow_robot", robot, {"target": target, "distance": distance,
                                                              "duration": duration}, client=client)

    def dock_and_charge(self, robot: str, dock: str | None = None, *, target_soc: float = 0.9,
                        client: str = "default") -> dict[str, Any]:
        params: dict[str, Any] = {"target_soc": target_soc} | ({"dock": dock} if dock is not None else {})
        return self._svc().submit_task("dock_and_charge", robot, params, client=client)

    def return_home(self, robot: str, *, client: str = "default") -> dict[str, Any]:
        return self._svc().submit_task("return_home", robot, {}, client=client)

    # ---- docks and battery ------------------------------------------------------------------------------

    def list_docks(self) -> list[dict[str, Any]]:
        return [{"name": n, "x": p.x, "y": p.y, "yaw": p.yaw} for n, p in self.docks.items()]

    def set_battery(self, robot: str, soc: float) -> float:
        """Set a robot's state of charge (0..1): for missions and tests that start from a given charge."""
        if not (isinstance(soc, int | float) and 0.0 <= soc <= 1.0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"soc must be in [0, 1], got {soc!r}")

        def do() -> float:
            self.registry.get(robot)
            self.battery.soc[self.world.table.index(robot)] = float(soc)
            self._publish()
            return float(soc)

        return self.call(do)

    # ---- allocation -------------------------------------------------------------------------------------

    def queue_task(self, type_name: str, params: dict[str, Any] | None = None, *, priority: int = 0,
                   earliest_start: float | None = None, deadline: float | None = None,
                   id: str | None = None) -> dict[str, Any]:
        """Queue a task for no robot in particular; `assign_tasks()` hands the queue out."""
        params = task_params.check(type_name, params, self.bounds)
        if len(self._unassigned) >= validation.MAX_TASKS:
            raise FleetError(ErrorCode.LIMIT_EXCEEDED, f"the queue holds {validation.MAX_TASKS} tasks already",
                             "assign_tasks first")
        req = make_request(parse_spec({"type": type_name, "params": params, "priority": priority,
                                       "earliest_start": earliest_start, "deadline": deadline, "id": id}), self.view)

        def do() -> dict[str, Any]:
            if req.id in self._unassigned:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a queued task '{req.id}' exists already")
            self._unassigned[req.id] = req
            return _request_dict(req)

        return self.call(do)

    def unassigned_tasks(self) -> list[dict[str, Any]]:
        return self.call(lambda: [_request_dict(r) for r in self._unassigned.values()])

    def assign_tasks(self, tasks: Sequence[dict[str, Any]] | None = None, robots: Sequence[str] | None = None,
                     method: str = "hungarian", dry_run: bool = False, *, client: str = "default",
                     **options: Any) -> Allocation:
        """Allocate `tasks` (default: the queue of unassigned tasks) to `robots` (default: every idle robot).

        Returns the assignment with each robot's order, planned paths, travel costs, ETAs and charge stops, and
        every task that could not be placed with the reason. Unless `dry_run`, the tasks (and charge stops)
        are submitted to the robots' task queues. Options: see AllocationOptions (cost, speed_factor, ...)."""
        if tasks is not None:
            validation.count("number of tasks", len(tasks), validation.MAX_TASKS)
            tasks = [_checked_spec(i, t, self.bounds) for i, t in enumerate(tasks)]
        opts = _options(method, options)
        requests = (None if tasks is None else [make_request(parse_spec(t), self.view) for t in tasks])
        inputs, now, keepouts, radius, pool = self.call(lambda: self._allocation_inputs(robots, opts))
        requests = pool if requests is None else requests
        b = self.config.battery
        energy = Energy(b.capacity_wh, b.drive_wh_per_m, b.idle_w, b.charge_w,
                        b.low_threshold if opts.reserve is None else opts.reserve, opts.charge_to)
        docks = {n: (p.x, p.y) for n, p in self.docks.items()}
        result = allocate(opts.method, now, inputs, requests, docks, self._travel(opts, keepouts, radius), energy)
        result.dry_run = dry_run
        if not dry_run:
            self.call(lambda: self._submit_allocation(result, requests, opts, client))
        return result

    def _allocation_inputs(self, robots: Sequence[str] | None, opts: AllocationOptions) -> tuple[
            list[RobotInput], float, list[Any], float, list[TaskRequest]]:
        """On the sim thread: the robots as they are now, the time, keep-outs, robot radius, the queue."""
        names = self._idle_robots() if robots is None else list(robots)
        out = []
        for n in names:
            self.registry.get(n)  # unknown → the error lists the robots
            if n in self.tasks.active or self.tasks.queues.get(n):
                raise FleetError(ErrorCode.BUSY, f"robot '{n}' has tasks already",
                                 "wait for them, cancel them, or leave the robot out of `robots`")
            if self.safety.is_estopped(n):
                raise FleetError(ErrorCode.ESTOPPED, f"robot '{n}' is e-stopped", "re-arm it or leave it out")
            p, spec = self.world.robot_pose(n), self.world.robot_spec(n)
            out.append(RobotInput(n, p.x, p.y, float(self.battery.soc[self.world.table.index(n)]),
                                  spec.limits.max_linear * opts.speed_factor))
        radius = max((self.world.robot_spec(n).footprint_radius for n in names),
                     default=self.default_spec().footprint_radius)
        return out, self.world.time, list(self._keepouts), radius, list(self._unassigned.values())

    def _idle_robots(self) -> list[str]:
        return [n for n in self.world.robot_names() if n not in self.tasks.active and not self.tasks.queues.get(n)
                and not self.safety.is_estopped(n) and self.safety.manual.get(n) is None]

    def _travel(self, opts: AllocationOptions, keepouts: list[Any], radius: float) -> Travel:
        if opts.cost == "euclidean":
            return EuclideanTravel()
        key = (opts.grid_resolution, round(radius, 4), len(keepouts))
        if self._grid_travel is None or self._grid_travel[0] != key:  # built once per world, radius, keep-outs
            cm = LayeredCostmap.from_world(self.world.description, robot_radius=radius,
                                           resolution=opts.grid_resolution)
            for poly in keepouts:
                cm.add_keepout(poly)
            self._grid_travel = (key, GridTravel(cm))
        return self._grid_travel[1]

    def _submit_allocation(self, result: Allocation, requests: list[TaskRequest], opts: AllocationOptions,
                           client: str) -> None:
        for robot in {a.robot for a in result.assignments}:  # check every lease before submitting anything
            holder = self.safety.holder(robot)
            if holder is not None and holder != client:
                raise FleetError(ErrorCode.LEASE_HELD, f"robot '{robot}' is controlled by client '{holder}'")
        by_id = {q.id: q for q in requests}
        prio: dict[str, float] = {}
        for a in sorted(result.assignments, key=lambda a: (a.robot, a.order)):
            q = by_id[a.request]
            # the manager orders a queue by priority: keep the plan's order by never raising it along a plan
            p = int(min(prio.get(a.robot, math.inf), a.priority))
            prio[a.robot] = p
            self.safety.manual.pop(a.robot, None)
            if a.charge_dock is not None:
                c = self.tasks.submit("dock_and_charge", a.robot, {"dock": a.charge_dock, "target_soc": opts.charge_to},
                                      priority=p)
                a.task_ids.append(c.id)
            nb = q.earliest_start if math.isfinite(q.earliest_start) else None
            a.task_ids.append(self.tasks.submit(q.type, a.robot, q.params, priority=p, not_before=nb).id)
            self._unassigned.pop(q.id, None)
        self.events.publish(self.world.time, "tasks_assigned", sorted({a.robot for a in result.assignments}),
                            f"{len(result.assignments)} tasks assigned by {result.method}, "
                            f"{len(result.infeasible)} infeasible", method=result.method,
                            assigned=len(result.assignments), infeasible=[i.request for i in result.infeasible])


def _checked_spec(i: int, t: Any, bounds: validation.Bounds) -> dict[str, Any]:
    """One task spec of assign_tasks: its params by its type's model, its other numbers finite and bounded."""
    if not isinstance(t, dict):
        raise validation.bad(f"tasks[{i}]", f"expected {{type, params, ...}}, got {type(t).__name__}")
    rest = {k: v for k, v in t.items() if k != "params"}
    validation.params(f"tasks[{i}]", rest, bounds)
    return rest | {"params": task_params.check(t.get("type"), t.get("params"), bounds, f"tasks[{i}].params")}


def _options(method: str, options: dict[str, Any]) -> AllocationOptions:
    try:
        return AllocationOptions.model_validate({"method": method, **options})
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"assign_tasks: {where}: {first['msg']}",
                         f"methods: {', '.join(sorted(METHODS))}; options: cost (path | euclidean), "
                         "grid_resolution, speed_factor, reserve, charge_to") from exc


def _request_dict(q: TaskRequest) -> dict[str, Any]:
    return {"id": q.id, "type": q.type, "params": _jsonable(q.params), "priority": q.priority,
            "earliest_start": q.earliest_start if math.isfinite(q.earliest_start) else None,
            "deadline": q.deadline if math.isfinite(q.deadline) else None,
            "start": list(q.profile.start), "end": list(q.profile.end), "work_m": q.profile.length}
