"""FleetService operations to inspect and clear keep-out zones (NavOps.add_keepout adds them)."""

from __future__ import annotations

from typing import Any

from fleet.core import ServiceCore


class KeepoutOps(ServiceCore):
    """Mixed into FleetService."""

    def list_keepouts(self) -> list[list[tuple[float, float]]]:
        return self.call(lambda: [list(p) for p in self._keepouts])

    def clear_keepouts(self) -> int:
        """Remove every keep-out zone from every robot's costmap (and the placement and allocation caches)."""

        def do() -> int:
            n = len(self._keepouts)
            self._keepouts.clear()
            for cm in self._costmaps.values():
                cm.clear_keepouts()
            caches: dict[str, Any] = self.__dict__
            if isinstance(caches.get("_placement"), dict):
                caches["_placement"].clear()  # FleetOps: where formation slots may go
            if "_grid_travel" in caches:
                caches["_grid_travel"] = None  # TaskOps: the allocator's path-cost grid
            if n:
                self.events.publish(self.world.time, "keepouts_cleared", (), f"{n} keep-out zones cleared")
            return n

        return self.call(do)
