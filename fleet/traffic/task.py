"""`traffic_go`: a go-to task driven by the traffic layer, so every door that submits tasks can use it: mission
`tasks:` (CLI, MCP mission tools), `svc.submit_task`, and — being allocatable — MCP `queue_task` +
`assign_tasks` and the allocator.

The first traffic_go task enables the layer with its default settings if the service has none; the settings are
fleet-wide, so they come from the mission's `traffic:` section (which enables it at setup) or
`fleet.traffic.enable_traffic`. The robot joins the layer when the
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
    from fleet.fleet_view import FleetView

@register_task
@dataclass(eq=False)
class TrafficGoTask(Task):
    """Drive to `goal` {x, y} through the traffic layer (PIBT plan, asynchronous execution)."""

    type_name = "traffic_go"
    allocatable = True  # MCP queue_task + assign_tasks, the allocator: like go_to
    layer: Any = None  # the TrafficManager, once begun

    @classmethod
    def work_profile(cls, params: dict[str, Any], view: FleetView) -> WorkProfile:
        g = pose_param(params)
        return WorkProfile(start=(g.x, g.y), end=(g.x, g.y))

    def validate(self, view: FleetView) -> None:
        pose_param(self.params)
        extra = sorted(set(self.params) - {"goal", "navigation"})  # navigation: added by missions, unused here
        if extra:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic_go does not take {', '.join(extra)}",
                             "parameters: goal {x, y}; the layer's settings are fleet-wide (mission traffic: key)")

    def begin(self, ctx: TaskContext) -> None:
        tm = ctx.view.traffic_layer({})  # enabled with the defaults if there is none
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
        tm = ctx.view.traffic_layer()
        if tm is None or self.robot not in tm.names:
            return self.fail(ctx.now, "the robot left the traffic layer")
        if tm.held(self.robot):  # admission: not started yet, the robot idles where it is
            self.progress["held"] = True
            return (0.0, 0.0)
        self.progress["held"] = False
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
        if tm is not None and tm.admission is not None:
            tm.admission.drop(self.robot)
        if tm is not None and self.robot in tm.names:
            i = tm.names.index(self.robot)
            tm.goal[i] = tm.sched.tail[i]
            tm.pending[i] = False
