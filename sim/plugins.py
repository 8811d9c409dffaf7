"""One registry shape for every plugin extension point that is chosen by `type:` with a pydantic config
(controllers, avoidance, swarm behaviours): registering a name twice raises, an unknown name lists the valid
ones, a typo in a setting names the field, and the factory gets plain keyword arguments."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from pydantic import BaseModel, ValidationError

from sim.errors import ErrorCode, FleetError, unknown_name

P = TypeVar("P")
C = TypeVar("C")


@dataclass(frozen=True, slots=True)
class PluginEntry(Generic[P]):
    config: type[BaseModel]
    factory: Callable[..., P]
    meta: dict[str, Any] = field(default_factory=dict)


class PluginRegistry(Generic[P]):
    def __init__(self, kind: str, code: ErrorCode = ErrorCode.INVALID_CONFIG) -> None:
        self.kind = kind  # "controller", "avoidance", ... as users read it in errors
        self.code = code  # the error code for unknown names and bad settings
        self._entries: dict[str, PluginEntry[P]] = {}

    def register(self, name: str, config: type[BaseModel], **meta: Any) -> Callable[[C], C]:
        """Class decorator: register `cls` under `name` with its config model."""

        def wrap(cls: C) -> C:
            if name in self._entries:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{self.kind} '{name}' is already registered",
                                 f"choose another name for the new {self.kind}")
            self._entries[name] = PluginEntry(config, cls, dict(meta))  # type: ignore[arg-type]
            return cls

        return wrap

    def names(self) -> list[str]:
        return sorted(self._entries)

    def configs(self) -> dict[str, type[BaseModel]]:
        """name → config model (its fields are what a caller may set besides `type`)."""
        return {n: self._entries[n].config for n in self.names()}

    def entry(self, name: str) -> PluginEntry[P]:
        if name not in self._entries:
            raise unknown_name(self.kind, name, self.names(), self.code)
        return self._entries[name]

    def config(self, spec: Mapping[str, Any]) -> Any:
        """Validate `{type: name, ...settings}` against the plugin's config model."""
        name = str(spec.get("type", ""))
        entry = self.entry(name)
        try:
            return entry.config.model_validate(dict(spec))
        except ValidationError as exc:
            fields = "; ".join(f"{'.'.join(str(p) for p in e['loc'])}: {e['msg']}" for e in exc.errors())
            raise FleetError(self.code, f"{self.kind} '{name}' settings: {fields}",
                             f"fields: {', '.join(entry.config.model_fields)}") from exc

    def make(self, spec: Mapping[str, Any], **extra: Any) -> P:
        """Build the plugin from its validated settings (minus `type`) and any extra keyword arguments."""
        cfg = self.config(spec)
        return self._entries[cfg.type].factory(**extra, **cfg.model_dump(exclude={"type"}))
