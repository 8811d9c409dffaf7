"""One registry for swarm behaviours, chosen by `type:`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from pydantic import BaseModel

from fleet.swarm.types import Behaviour, BehaviourConfig
from sim.errors import ErrorCode
from sim.plugins import PluginRegistry

_REGISTRY: PluginRegistry[Behaviour] = PluginRegistry("behaviour", ErrorCode.INVALID_ARGUMENT)
C = TypeVar("C")


def register_behaviour(name: str, config: type[BehaviourConfig], min_robots: int = 1) -> Callable[[C], C]:
    """Class decorator: register a behaviour under `name`; registering a name twice raises."""
    return _REGISTRY.register(name, config, min_robots=min_robots)


def behaviour_configs() -> dict[str, type[BaseModel]]:
    """name → the swarm behaviour's config model (typed schemas for the MCP tools)."""
    return _REGISTRY.configs()


def behaviour_names() -> list[str]:
    return _REGISTRY.names()


def min_robots(name: str) -> int:
    return int(_REGISTRY.entry(name).meta["min_robots"])


def behaviour_config(spec: Mapping[str, Any]) -> BehaviourConfig:
    cfg: BehaviourConfig = _REGISTRY.config(spec)
    return cfg


def make_behaviour(spec: Mapping[str, Any]) -> Behaviour:
    """Validate `{type: name, ...params}` and build the behaviour from plain keyword arguments."""
    return _REGISTRY.make(spec)
