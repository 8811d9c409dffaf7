"""Result and state types of World operations."""

from __future__ import annotations

from dataclasses import dataclass

from sim.types import Pose3D


@dataclass(frozen=True, slots=True)
class CommandResult:
    """What a velocity command did: requested vs applied (after clamping), and why it differs."""

    robot: str
    requested_v: float
    requested_w: float
    applied_v: float
    applied_w: float
    clamped: bool
    reason: str
    stamp: float


@dataclass(frozen=True, slots=True)
class SensorFault:
    dropout: bool = False
    noise_scale: float = 1.0


@dataclass(frozen=True, slots=True)
class ModelState:
    name: str
    pose: Pose3D
    linear_velocity: tuple[float, float, float]
    angular_velocity: tuple[float, float, float]
    static: bool
    kind: str  # "sdf", "urdf", "ground" or "robot"
