"""One registry for avoidance plugins (the `avoidance: {type: ...}` section of FleetConfig)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from pydantic import BaseModel

from fleet.avoidance.types import AvoidanceConfig
from sim.plugins import PluginRegistry

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

Command = tuple[float, float]


class Avoidance(Protocol):
    """A fleet.control.VelocityFilter that also says which settings it runs with."""

    name: str

    def filter(self, view: FleetView, desired: dict[str, Command]) -> dict[str, Command]: ...

    def settings(self) -> dict[str, Any]: ...


_REGISTRY: PluginRegistry[Avoidance] = PluginRegistry("avoidance")
C = TypeVar("C")


def register_avoidance(name: str, config: type[AvoidanceConfig]) -> Callable[[C], C]:
    """Class decorator: register an avoidance plugin under `name`; registering a name twice raises."""
    return _REGISTRY.register(name, config)


def avoidance_configs() -> dict[str, type[BaseModel]]:
    """name → the avoidance plugin's config model (typed schemas for the MCP tools)."""
    return _REGISTRY.configs()


def avoidance_names() -> list[str]:
    return _REGISTRY.names()


def avoidance_config(spec: Mapping[str, Any]) -> AvoidanceConfig:
    """Validate `{type: name, ...settings}`: an unknown type lists the valid ones, a typo names the field."""
    cfg: AvoidanceConfig = _REGISTRY.config(spec)
    return cfg


def make_avoidance(spec: Mapping[str, Any]) -> Avoidance:
    """Build a plugin from its config; the constructor gets plain keyword arguments."""
    return _REGISTRY.make(spec)
