"""One registry for swarm behaviours, chosen by `type:`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from pydantic import ValidationError

from fleet.swarm.types import Behaviour, BehaviourConfig
from sim.errors import ErrorCode, FleetError, unknown_name


@dataclass(frozen=True, slots=True)
class _Entry:
    config: type[BehaviourConfig]
    factory: Callable[..., Behaviour]
    min_robots: int


_REGISTRY: dict[str, _Entry] = {}
C = TypeVar("C")


def register_behaviour(name: str, config: type[BehaviourConfig], min_robots: int = 1) -> Callable[[C], C]:
    """Class decorator: register a behaviour under `name`; registering a name twice raises."""

    def wrap(cls: C) -> C:
        if name in _REGISTRY:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"behaviour '{name}' is already registered",
                             "choose another name for the new behaviour")
        _REGISTRY[name] = _Entry(config, cls, min_robots)  # type: ignore[arg-type]
        return cls

    return wrap


def behaviour_names() -> list[str]:
    return sorted(_REGISTRY)


def min_robots(name: str) -> int:
    return _entry(name).min_robots


def _entry(name: str) -> _Entry:
    if name not in _REGISTRY:
        raise unknown_name("behaviour", name, behaviour_names(), ErrorCode.INVALID_ARGUMENT)
    return _REGISTRY[name]


def behaviour_config(spec: Mapping[str, Any]) -> BehaviourConfig:
    name = str(spec.get("type", ""))
    entry = _entry(name)
    try:
        return entry.config.model_validate(dict(spec))
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"behaviour '{name}' parameters: {exc}",
                         f"fields: {', '.join(entry.config.model_fields)}") from exc


def make_behaviour(spec: Mapping[str, Any]) -> Behaviour:
    """Validate `{type: name, ...params}` and build the behaviour from plain keyword arguments."""
    cfg = behaviour_config(spec)
    return _REGISTRY[cfg.type].factory(**cfg.model_dump(exclude={"type"}))
