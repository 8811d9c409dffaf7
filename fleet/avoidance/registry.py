"""One registry for avoidance plugins (the `avoidance: {type: ...}` section of FleetConfig)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from pydantic import ValidationError

from fleet.avoidance.types import AvoidanceConfig
from sim.errors import ErrorCode, FleetError, unknown_name

if TYPE_CHECKING:
    from fleet.service import FleetService

Command = tuple[float, float]


class Avoidance(Protocol):
    """A fleet.control.VelocityFilter that also says which settings it runs with."""

    name: str

    def filter(self, service: FleetService, desired: dict[str, Command]) -> dict[str, Command]: ...

    def settings(self) -> dict[str, Any]: ...


@dataclass(frozen=True, slots=True)
class _Entry:
    config: type[AvoidanceConfig]
    factory: Callable[..., Avoidance]


_REGISTRY: dict[str, _Entry] = {}
C = TypeVar("C")


def register_avoidance(name: str, config: type[AvoidanceConfig]) -> Callable[[C], C]:
    """Class decorator: register an avoidance plugin under `name`; registering a name twice raises."""

    def wrap(cls: C) -> C:
        if name in _REGISTRY:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"avoidance '{name}' is already registered",
                             "choose another name for the new plugin")
        _REGISTRY[name] = _Entry(config, cls)  # type: ignore[arg-type]
        return cls

    return wrap


def avoidance_names() -> list[str]:
    return sorted(_REGISTRY)


def avoidance_config(spec: Mapping[str, Any]) -> AvoidanceConfig:
    """Validate `{type: name, ...settings}`: an unknown type lists the valid ones, a typo names the field."""
    name = str(spec.get("type", ""))
    entry = _REGISTRY.get(name)
    if entry is None:
        raise unknown_name("avoidance", name, avoidance_names(), ErrorCode.INVALID_CONFIG)
    try:
        return entry.config.model_validate(dict(spec))
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"avoidance '{name}' settings: {exc}",
                         f"fields: {', '.join(entry.config.model_fields)}") from exc


def make_avoidance(spec: Mapping[str, Any]) -> Avoidance:
    """Build a plugin from its config; the constructor gets plain keyword arguments."""
    cfg = avoidance_config(spec)
    return _REGISTRY[cfg.type].factory(**cfg.model_dump(exclude={"type"}))
