"""Task types (registered by `type:`) and the task manager. Importing this package registers the built-ins."""

from fleet.tasks import basic  # noqa: F401  (registers wait, stop, go_to)
from fleet.tasks.base import Task, TaskContext, register_task, task_class, task_types
from fleet.tasks.manager import TaskManager

__all__ = ["Task", "TaskContext", "TaskManager", "register_task", "task_class", "task_types"]
