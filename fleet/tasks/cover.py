"""cover_area: cover a polygon (with holes) along a planning.coverage path, reporting coverage achieved.

The plan comes from planning.coverage.plan_coverage; the navigator tracks it with `follow_route`. The
coverage reported is measured, not planned: the disc tool swept along the robot's actual trajectory,
intersected with the region (the same measure as CoveragePlan.coverage_pct, on the driven path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.errors import ShapelyError
from shapely.geometry import Polygon

from fleet.tasks.base import Command, TaskContext, register_task
from fleet.tasks.basic import NavTask
from fleet.tasks.types import WorkProfile
from planning.coverage import coverage_stats, plan_coverage
from planning.nav_types import CoveragePlan, NavState
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

DEFAULT_TOOL_WIDTH = 0.5  # m
TRACE_STEP = 0.05  # m between recorded trajectory points
MEASURE_EVERY_S = 2.0  # sim seconds between coverage measurements while running


def region(params: dict[str, Any]) -> Polygon:
    """`polygon`: exterior [[x, y], ...] (≥ 3 vertices); `holes`: a list of such rings."""
    try:
        poly = Polygon(params.get("polygon"), params.get("holes") or [])
    except (TypeError, ValueError, AttributeError, ShapelyError) as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"cover_area: bad polygon: {exc}",
                         "polygon: [[x, y], ...] with ≥ 3 vertices; holes: a list of such rings") from exc
    if poly.is_empty or not poly.is_valid or poly.area <= 0:
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         f"cover_area: the polygon is not valid ({shapely.is_valid_reason(poly)})",
                         "give ≥ 3 vertices in order, without self-intersections, holes inside it")
    return poly


def plan_for(params: dict[str, Any], start: tuple[float, float] | None = None) -> CoveragePlan:
    return plan_coverage(region(params), tool_width=float(params.get("tool_width", DEFAULT_TOOL_WIDTH)),
                         overlap=float(params.get("overlap", 0.1)), pattern=params.get("pattern", "boustrophedon"),
                         angle=params.get("angle"), start=start)


@register_task
@dataclass(eq=False)
class CoverAreaTask(NavTask):
    """Cover `polygon` minus `holes` with a tool `tool_width` wide (default 0.5 m), passes overlapping by
    `overlap` (0.1), `pattern` boustrophedon | spiral. With `min_coverage_pct` it fails if the coverage
    measured at the end is lower."""

    type_name = "cover_area"
    allocatable = True
    plan: CoveragePlan | None = None
    trace: list[tuple[float, float]] = field(default_factory=list)
    _measured_at: float = -math.inf
    _coverage: float = 0.0

    def validate(self, view: FleetView) -> None:
        plan_for(self.params)  # checks the polygon, tool and pattern now, so bad input fails at submit

    @classmethod
    def work_profile(cls, params: dict[str, Any], view: FleetView) -> WorkProfile:
        p = plan_for(params)
        path = np.asarray(shapely.LineString(p.path).simplify(0.05).coords)
        (x0, y0), (x1, y1) = p.path[0], p.path[-1]
        return WorkProfile(start=(float(x0), float(y0)), end=(float(x1), float(y1)), length=p.length,
                           path=path)

    def begin(self, ctx: TaskContext) -> None:
        here = ctx.pose(self.robot)
        self.plan = plan_for(self.params, start=(here.x, here.y))
        self.trace = [(here.x, here.y)]
        self.navigator(ctx).follow_route(self.plan.path, ctx.now)

    def step(self, ctx: TaskContext) -> Command:
        assert self.plan is not None
        cmd, state = self.drive(ctx)
        p = ctx.pose(self.robot)
        if math.hypot(p.x - self.trace[-1][0], p.y - self.trace[-1][1]) >= TRACE_STEP:
            self.trace.append((p.x, p.y))
        done = state.done
        if done or ctx.now - self._measured_at >= MEASURE_EVERY_S:
            self._coverage = self.measured_coverage()
            self._measured_at = ctx.now
        self.progress.update({"coverage_pct": round(self._coverage, 2),
                              "planned_coverage_pct": round(self.plan.coverage_pct, 2),
                              "path_length": round(self.plan.length, 2), "passes": self.plan.passes})
        if state is NavState.FAILED:
            return self.fail(ctx.now, f"{self.reason or 'navigation failed'} (covered {self._coverage:.1f}%)")
        if state is NavState.SUCCEEDED:
            need = float(self.params.get("min_coverage_pct", 0.0))
            if self._coverage < need:
                return self.fail(ctx.now, f"covered {self._coverage:.1f}% < min_coverage_pct {need:.1f}%")
            return self.succeed(ctx.now)
        return cmd

    def measured_coverage(self) -> float:
        """Coverage % of the region by the tool swept along the trajectory driven so far."""
        assert self.plan is not None
        cov, _ = coverage_stats(np.asarray(self.trace), region(self.params), self.plan.tool_width)
        return cov
