"""FleetService operations for task allocation and task-type extras (owned by the tasks/allocation work)."""

from __future__ import annotations

from fleet.core import ServiceCore


class TaskOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_task_ops(self) -> None:
        """Called from FleetService._build after the task manager exists."""
