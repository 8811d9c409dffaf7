"""One registry per extension point of a mission file (`type:` key): assertions and scripted events.

Each entry pairs a pydantic config model (its `type` field a Literal of the name) with the code that runs
it. Registering a name twice raises; an unknown name lists the valid ones. The package `__init__` imports
the built-ins, so lookups never depend on import order.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

from sim.config import StrictModel
from sim.errors import ErrorCode, unknown_name

F = TypeVar("F", bound=Callable[..., Any])


class Registry(Generic[F]):
    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, tuple[type[StrictModel], F]] = {}

    def register(self, name: str, model: type[StrictModel]) -> Callable[[F], F]:
        """Decorator for the implementation of `name`, configured by `model`."""

        def deco(fn: F) -> F:
            if name in self._entries:
                raise ValueError(f"{self.kind} '{name}' is already registered")
            if model.model_fields["type"].default != name:
                raise ValueError(f"{model.__name__}.type must default to '{name}'")
            self._entries[name] = (model, fn)
            return fn

        return deco

    def get(self, name: str) -> F:
        if name not in self._entries:
            raise unknown_name(self.kind, name, list(self._entries), ErrorCode.INVALID_CONFIG)
        return self._entries[name][1]

    def names(self) -> list[str]:
        return sorted(self._entries)

    def models(self) -> tuple[type[StrictModel], ...]:
        return tuple(self._entries[n][0] for n in self.names())
