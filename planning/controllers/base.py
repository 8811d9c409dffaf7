"""The Controller protocol and its registry: a controller is chosen by the `type:` key of its config.

Each controller module registers a class with a pydantic config model; `make_controller` validates the
config (a typo is an error naming the field), then hands plain keyword arguments to the constructor.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, Protocol, TypeVar, runtime_checkable

from pydantic import Field

from planning.controllers.reference import PathReference
from planning.nav_types import ControlOutput
from planning.types import Costmap
from sim.config import StrictModel
from sim.plugins import PluginRegistry
from sim.robot_spec import LimitsSpec
from sim.types import Pose2D


@runtime_checkable
class Controller(Protocol):
    """Turns (pose, twist, reference) into a body twist command every control period."""

    name: str

    def reset(self) -> None:
        """Forget warm starts and progress (a new path or a recovery happened)."""
        ...

    def compute(self, pose: Pose2D, twist: tuple[float, float], ref: PathReference, *, now: float,
                costmap: Costmap | None = None) -> ControlOutput: ...


class ControllerConfig(StrictModel):
    """Fields every controller accepts; subclasses add their tuning."""

    type: str
    min_linear: float = Field(0.0, le=0.0, description="most negative forward speed allowed, m/s")


_REGISTRY: PluginRegistry[Controller] = PluginRegistry("controller")
C = TypeVar("C")


def register_controller(name: str, config: type[ControllerConfig]) -> Callable[[C], C]:
    """Class decorator: register `cls` under `name`; registering a name twice raises."""
    return _REGISTRY.register(name, config)


def controller_names() -> list[str]:
    return _REGISTRY.names()


def make_controller(config: Mapping[str, Any] | ControllerConfig, limits: LimitsSpec) -> Controller:
    """Build a controller from `{type: name, ...tuning}` and the robot's velocity/acceleration limits."""
    data = config.model_dump() if isinstance(config, ControllerConfig) else dict(config)
    return _REGISTRY.make(data, max_v=limits.max_linear, max_w=limits.max_angular, max_a=limits.max_linear_accel,
                          max_alpha=limits.max_angular_accel)


class RateLimiter:
    """Clamps a command to the velocity bounds and to the accelerations reachable since the last call."""

    def __init__(self, *, max_v: float, max_w: float, max_a: float, max_alpha: float, min_v: float) -> None:
        self.max_v, self.max_w, self.max_a, self.max_alpha, self.min_v = max_v, max_w, max_a, max_alpha, min_v
        self.last: tuple[float, float] | None = None
        self._t: float | None = None

    def reset(self) -> None:
        self.last, self._t = None, None

    def previous(self, twist: tuple[float, float]) -> tuple[float, float]:
        """The command the next one must stay close to: the last one sent, else the measured twist."""
        return self.last if self.last is not None else twist

    def period(self, now: float, default: float) -> float:
        return default if self._t is None or now <= self._t else now - self._t

    def __call__(self, v: float, w: float, now: float, twist: tuple[float, float],
                 default_dt: float) -> tuple[float, float]:
        dt = self.period(now, default_dt)
        pv, pw = self.previous(twist)
        v = min(max(v, self.min_v, pv - self.max_a * dt), self.max_v, pv + self.max_a * dt)
        w = min(max(w, -self.max_w, pw - self.max_alpha * dt), self.max_w, pw + self.max_alpha * dt)
        self.last, self._t = (v, w), now
        return v, w


def angle_diff(a: float, b: float) -> float:
    """a - b wrapped to (-pi, pi]."""
    return math.atan2(math.sin(a - b), math.cos(a - b))
