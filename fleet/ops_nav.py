"""FleetService operations for navigation: navigators per robot, costmaps, tasks, plans, maps."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from fleet import task_params, validation
from fleet.core import ServiceCore
from planning import LayeredCostmap, OccupancyGrid, PlanResult, get_planner, rasterize_world
from planning.grid import UNKNOWN_CELL
from planning.navigator import Navigator, NavigatorConfig, make_navigator
from sim import FleetError, Pose2D
from sim.errors import ErrorCode

if TYPE_CHECKING:
    pass
    from fleet.tasks.base import Task


class NavOps(ServiceCore):
    """Mixed into FleetService."""

    _nav_cover: list[tuple[float, float]]  # goals the planning map must cover (it grows for them)

    def static_grid(self) -> OccupancyGrid:
        """The world rasterised at robot height once per world (shared by every robot's costmap)."""
        if self._static_grid is None:
            self._static_grid = rasterize_world(self.world.description, resolution=self.config.costmap_resolution,
                                                bounds=self.map_bounds())
        assert self._static_grid is not None
        return self._static_grid

    def map_bounds(self) -> tuple[float, float, float, float]:
        """The planning map's extent: the world's obstacles (+1 m), at least 20 m × 20 m about the origin, every
        robot's position ± 5 m and every goal given so far ± 5 m (no artificial bounds: the map grows)."""
        xs0, ys0, xs1, ys1 = self.world.description.bounds(margin=1.0)
        lo = [min(xs0, -10.0), min(ys0, -10.0)]
        hi = [max(xs1, 10.0), max(ys1, 10.0)]
        spots = [(p.x, p.y) for p in map(self.world.robot_pose, self.world.robot_names())]
        for x, y in spots + getattr(self, "_nav_cover", []):
            lo = [min(lo[0], x - 5.0), min(lo[1], y - 5.0)]
            hi = [max(hi[0], x + 5.0), max(hi[1], y + 5.0)]
        return (lo[0], lo[1], hi[0], hi[1])

    def cover(self, x: float, y: float) -> None:
        """Grow the planning map (and drop the costmaps built on the old one) when (x, y) ± 1 m is outside it."""
        if not hasattr(self, "_nav_cover"):
            self._nav_cover = []
        self._nav_cover.append((float(x), float(y)))
        if self._static_grid is not None:
            x0, y0, x1, y1 = self._static_grid.bounds
            if not (x0 + 1.0 <= x <= x1 - 1.0 and y0 + 1.0 <= y <= y1 - 1.0):
                self._static_grid = None
                self._costmaps.clear()

    def costmap_for(self, robot: str) -> LayeredCostmap:
        """Each robot's own costmap (its obstacle layer sees what its lidar sees), keep-outs shared."""
        if robot not in self._costmaps:
            spec = self.world.robot_spec(robot)
            source = self.nav_config().map_source
            grid = self.static_grid()
            if source == "sensors":  # a robot that must not read the world file: everything unknown at first
                grid = OccupancyGrid.empty(grid.bounds, grid.resolution, fill=UNKNOWN_CELL)
            cm = LayeredCostmap(grid, robot_radius=spec.footprint_radius, sensor_offset=(spec.mast.x_offset, 0.0),
                                allow_unknown=source == "sensors")
            for poly in self._keepouts:
                cm.add_keepout(poly)
            self._costmaps[robot] = cm
        return self._costmaps[robot]

    def nav_config(self, overrides: dict[str, Any] | None = None) -> NavigatorConfig:
        merged = {**self.config.navigation, **(overrides or {})}
        try:
            return NavigatorConfig.model_validate(merged)
        except ValidationError as exc:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"navigation settings: {validation.summarize(exc)}") from exc

    def make_navigator(self, robot: str, overrides: dict[str, Any] | None = None) -> Navigator:
        return make_navigator(self.nav_config(overrides), costmap=self.costmap_for(robot),
                              spec=self.world.robot_spec(robot))

    # ---- front-door operations -------------------------------------------------------------------------

    def submit_task(self, type_name: str, robot: str, params: dict[str, Any] | None = None, *,
                    priority: int = 0, client: str = "default") -> dict[str, Any]:
        """Queue a task; returns its id at once (long actions report through task_status). Refused while the
        robot (or the fleet) is e-stopped: a queued goal must not drive off on re-arm."""
        params = task_params.check(type_name, params, self.bounds)

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            if self.safety.is_estopped(robot):
                raise FleetError(ErrorCode.ESTOPPED, f"robot '{robot}' is e-stopped; no task is accepted",
                                 "rearm it (or the fleet) first, then send the goal again")
            holder = self.safety.holder(robot)
            if holder is not None and holder != client:
                raise FleetError(ErrorCode.LEASE_HELD, f"robot '{robot}' is controlled by client '{holder}'",
                                 "wait for its lease to lapse or ask that client to release it")
            if self.safety.manual.get(robot) is not None:  # a new task takes over from manual driving
                self.safety.manual.pop(robot)
            goal = (params or {}).get("goal")
            if isinstance(goal, Pose2D):
                self.cover(goal.x, goal.y)
            elif isinstance(goal, dict) and all(isinstance(goal.get(k), int | float) for k in ("x", "y")):
                self.cover(float(goal["x"]), float(goal["y"]))
            return self.tasks.submit(type_name, robot, params, priority=priority).to_dict()

        return self.call(do)

    def navigate(self, robot: str, goal: Pose2D, *, align_yaw: bool = False,
                 client: str = "default") -> dict[str, Any]:
        return self.submit_task("go_to", robot, {"goal": goal, "align_yaw": align_yaw}, client=client)

    def task_status(self, task_id: str) -> dict[str, Any]:
        return self.call(lambda: self.tasks.get(task_id).to_dict())

    def cancel_task(self, task_id: str) -> dict[str, Any]:
        return self.call(lambda: self.tasks.cancel(task_id).to_dict())

    def list_tasks(self, robot: str | None = None, include_done: bool = False) -> list[dict[str, Any]]:
        def do() -> list[dict[str, Any]]:
            out: list[Task] = [t for t in self.tasks.tasks.values() if (robot is None or t.robot == robot)
                               and (include_done or not t.state.done)]
            return [t.to_dict() for t in out]

        return self.call(do)

    def plan_path(self, robot: str, goal: Pose2D, planner: str | None = None,
                  start: Pose2D | None = None) -> PlanResult:
        """Preview a plan for `robot` (nothing moves)."""
        validation.pose("goal", goal, self.bounds)
        if start is not None:
            validation.pose("start", start, self.bounds)

        def do() -> PlanResult:
            s = start or self.world.robot_pose(robot)
            self.cover(goal.x, goal.y)
            cfg = self.nav_config()
            spec = dict(cfg.planner) if planner is None else {"type": planner}
            return get_planner(**spec).plan(s, goal, self.costmap_for(robot))

        return self.call(do)

    def add_keepout(self, polygon: list[tuple[float, float]]) -> int:
        """Forbid a polygonal zone for every robot's planner (and robots spawned later)."""
        polygon = validation.polygon("polygon", polygon, self.bounds)

        def do() -> int:
            self._keepouts.append([(float(x), float(y)) for x, y in polygon])
            for cm in self._costmaps.values():
                cm.add_keepout(polygon)
            return len(self._keepouts)

        return self.call(do)
