"""The planner registry: one per extension point, chosen by a `type:` name (STYLE.md §5)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from planning.types import GlobalPlanner
from sim.errors import ErrorCode, FleetError, unknown_name

PlannerFactory = Callable[..., GlobalPlanner]
_PLANNERS: dict[str, PlannerFactory] = {}


def register_planner(name: str, factory: PlannerFactory) -> None:
    """Register `factory(**kwargs) -> GlobalPlanner` under `name`; a name can be registered once."""
    if name in _PLANNERS:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"planner '{name}' is already registered",
                         "choose a different name")
    _PLANNERS[name] = factory


def get_planner(type: str, **kwargs: Any) -> GlobalPlanner:  # `type:` is the config key
    """Build the planner registered as `type` with keyword arguments (its config section)."""
    factory = _PLANNERS.get(type)
    if factory is None:
        raise unknown_name("planner", type, list(_PLANNERS), ErrorCode.INVALID_ARGUMENT)
    try:
        return factory(**kwargs)
    except TypeError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"bad arguments for planner '{type}': {exc}",
                         "check the planner's options") from exc


def planner_names() -> list[str]:
    return sorted(_PLANNERS)
