"""dock_and_charge: drive to a dock, then stand still on it until the battery reaches a target charge.

The battery bank (fleet/battery.py) charges a robot that is still within `dock_radius` of a dock; this
task only has to get there and wait. A robot that stops gaining charge on the dock fails the task
rather than waiting forever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from fleet.tasks.base import Command, TaskContext, register_task
from fleet.tasks.basic import NavTask
from fleet.tasks.docks import check_dock, nearest_dock
from planning.nav_types import NavState
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

DEFAULT_TARGET_SOC = 0.9
STALL_S = 30.0  # on the dock this long without gaining charge: something is wrong, say so


@register_task
@dataclass(eq=False)
class DockAndChargeTask(NavTask):
    """Go to `dock` (a name; default the nearest dock no other robot is using) and wait there until the
    state of charge is at least `target_soc` (default 0.9)."""

    type_name = "dock_and_charge"
    dock: str = ""
    phase: str = "driving"  # driving | charging
    _best_soc: float = -1.0
    _best_t: float = 0.0

    def validate(self, view: FleetView) -> None:
        check_dock(view.docks, self.params.get("dock"))
        t = self.params.setdefault("target_soc", DEFAULT_TARGET_SOC)
        if not isinstance(t, int | float) or not 0 < t <= 1:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"target_soc must be in (0, 1], got {t!r}", "e.g. 0.9")

    def begin(self, ctx: TaskContext) -> None:
        view = ctx.view
        name = self.params.get("dock")
        if name is None:
            p = ctx.pose(self.robot)
            taken = [t.dock for t in view.active_tasks().values() if isinstance(t, DockAndChargeTask) and t is not self]
            name = nearest_dock(view.docks, p.x, p.y, taken)
        self.dock = name
        self.navigator(ctx).set_goal(view.docks[name], ctx.now)

    def step(self, ctx: TaskContext) -> Command:
        view = ctx.view
        soc = view.battery_soc(self.robot)
        target = float(self.params["target_soc"])
        if self.phase == "driving":
            cmd, state = self.drive(ctx)
            self._report(view, soc, target)
            if state is NavState.FAILED:
                return self.fail(ctx.now, f"could not reach dock {self.dock}: {self.reason or 'navigation failed'}")
            if state is not NavState.SUCCEEDED:
                return cmd
            self.phase, self._best_soc, self._best_t = "charging", soc, ctx.now
            view.publish(ctx.now, "docked", (self.robot,), f"{self.robot} on {self.dock}", dock=self.dock,
                         soc=soc, task=self.id)
        dock = view.docks[self.dock]
        if ctx.pose(self.robot).distance_to(dock) > view.battery_config.dock_radius:  # pushed off: drive back
            self.phase = "driving"
            self.navigator(ctx).set_goal(dock, ctx.now)
            return (0.0, 0.0)
        self._report(view, soc, target)
        if soc >= target - 1e-9:
            view.publish(ctx.now, "charged", (self.robot,), f"{self.robot} charged to {soc:.0%}",
                         dock=self.dock, soc=soc, task=self.id)
            return self.succeed(ctx.now)
        if soc > self._best_soc + 1e-6:
            self._best_soc, self._best_t = soc, ctx.now
        elif ctx.now - self._best_t > STALL_S:
            return self.fail(ctx.now, f"not charging on {self.dock}: state of charge stuck at {soc:.1%}")
        return (0.0, 0.0)

    def _report(self, view: FleetView, soc: float, target: float) -> None:
        b = view.battery_config
        net_w = b.charge_w - b.idle_w
        eta = max(0.0, target - soc) * b.capacity_wh / net_w * 3600.0 if net_w > 0 else math.inf
        self.progress.update({"dock": self.dock, "phase": self.phase, "soc": round(soc, 4), "target_soc": target,
                              "charge_time_s": eta})
