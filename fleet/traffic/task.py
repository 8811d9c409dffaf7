"""`traffic_go`: a go-to task driven by the traffic layer, so every door that submits tasks can use it: mission
`tasks:` (CLI, MCP mission tools), `svc.submit_task`, and — being allocatable — MCP `queue_task` +
`assign_tasks` and the allocator.

The first traffic_go task enables the layer if the service has none (settings from the task's `traffic:`
parameter, or the mission's `traffic:` section, which enables it at setup). The robot joins the layer when the
task begins: it must stand at rest at the centre of a free traffic cell (the error names the nearest one).
When the task ends the robot leaves the layer if nothing is scheduled for it any more (PIBT may still have a
push planned for it; it then stays, at rest, until that has run).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fleet.tasks.base import Command, Task, TaskContext, pose_param, register_task
from fleet.tasks.types import WorkProfile
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService
    from fleet.traffic.manager import TrafficManager

SETTINGS = ("cell", "speed", "window", "stall_s", "lane_cost", "seed", "priority")


def traffic_layer(service: FleetService) -> TrafficManager | None:
    """The service's traffic layer, if one is enabled."""
    from fleet.traffic.manager import TrafficManager

    return next((s for s in service.control.sources if isinstance(s, TrafficManager)), None)


def ensure_traffic(service: FleetService, settings: dict[str, Any]) -> TrafficManager:
    """The service's traffic layer, enabled with `settings` when there is none (on the sim thread)."""
    from fleet.traffic.manager import TrafficManager

    tm = traffic_layer(service)
    if tm is None:
        unknown = sorted(set(settings) - set(SETTINGS))
        if unknown:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown traffic setting(s) {', '.join(unknown)}",
                             f"valid: {', '.join(SETTINGS)}")
        tm = TrafficManager(service, **settings)
        service.control.sources.insert(0, tm)
    return tm


@register_task
@dataclass(eq=False)
class TrafficGoTask(Task):
    """Drive to `goal` {x, y} through the traffic layer (PIBT plan, asynchronous execution). Optional
    `traffic`: {cell, speed, window, stall_s, lane_cost, seed} used if this task enables the layer."""

    type_name = "traffic_go"
    allocatable = True  # MCP queue_task + assign_tasks, the allocator: like go_to
    layer: Any = None  # the TrafficManager, once begun

    @classmethod
    def work_profile(cls, params: dict[str, Any], service: FleetService) -> WorkProfile:
        g = pose_param(params)
        return WorkProfile(start=(g.x, g.y), end=(g.x, g.y))

    def validate(self, service: FleetService) -> None:
        pose_param(self.params)
        extra = sorted(set(self.params) - {"goal", "traffic"})
        if extra:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic_go does not take {', '.join(extra)}",
                             "parameters: goal {x, y}, traffic {" + ", ".join(SETTINGS) + "}")
        settings = self.params.get("traffic", {})
        if not isinstance(settings, dict) or set(settings) - set(SETTINGS):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic_go: bad traffic settings {settings!r}",
                             f"a mapping with keys among {', '.join(SETTINGS)}")

    def begin(self, ctx: TaskContext) -> None:
        tm = ensure_traffic(ctx.service, dict(self.params.get("traffic", {})))
        if self.robot not in tm.names:
            p = ctx.pose(self.robot)
            node = tm.grid.nearest_node(p.x, p.y)
            try:
                tm.add(self.robot)
            except FleetError as exc:
                x, y = tm.grid.xy[node]
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{exc.message}", f"the nearest traffic cell centre "
                                 f"is ({x:.2f}, {y:.2f}); cells are {tm.grid.cell:g} m, one robot each") from exc
        self.layer = tm
        g = pose_param(self.params)
        node = tm.go(self.robot, g.x, g.y)
        x, y = tm.grid.xy[node]
        self.progress = {"goal_cell": [float(x), float(y)]}

    def step(self, ctx: TaskContext) -> Command:
        tm = traffic_layer(ctx.service)
        if tm is None or self.robot not in tm.names:
            return self.fail(ctx.now, "the robot left the traffic layer")
        i = tm.names.index(self.robot)
        field = tm.grid.fields.to(int(tm.goal[i]))
        self.progress["cell_cost_to_go"] = float(field[tm.a[i]])
        if not tm.pending[i] and tm.a[i] == tm.goal[i] and tm.a[i] == tm.b[i]:
            tm.release(self.robot, "task done")
            return self.succeed(ctx.now)
        return (0.0, 0.0)  # the traffic layer's command wins (it comes first in the control loop)

    def cancel(self, reason: str) -> None:
        """No new moves are planned for the robot; those already scheduled run (others depend on them)."""
        tm = self.layer
        if tm is not None and self.robot in tm.names:
            i = tm.names.index(self.robot)
            tm.goal[i] = tm.sched.tail[i]
            tm.pending[i] = False
