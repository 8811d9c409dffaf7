"""Task types (registered by `type:`) and the task manager. Importing this package registers the built-ins."""

import fleet.traffic.task  # noqa: F401  (registers traffic_go: the traffic layer's task type, fleet/traffic)
from fleet.tasks import basic, charge, cover, follow, waypoints  # noqa: F401  (register the built-in types)
from fleet.tasks.base import Task, TaskContext, allocatable_types, register_task, task_class, task_types
from fleet.tasks.docks import dock_table, nearest_dock
from fleet.tasks.manager import TaskManager
from fleet.tasks.types import WorkProfile

__all__ = ["Task", "TaskContext", "TaskManager", "WorkProfile", "allocatable_types", "dock_table", "nearest_dock",
           "register_task", "task_class", "task_types"]
