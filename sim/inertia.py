"""Closed-form inertia tensors of solid primitives, about their centre of mass, in the shape's own frame.

URDF and SDF write a tensor as (ixx, ixy, ixz, iyy, iyz, izz). A physical tensor is symmetric positive
definite and its principal moments satisfy the triangle inequality (I1 + I2 ≥ I3): `is_physical` checks
both, so a hand-edited robot file with impossible numbers can be caught before the physics engine sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from sim.errors import ErrorCode, FleetError

Axis = Literal["x", "y", "z"]


@dataclass(frozen=True, slots=True)
class Inertia:
    ixx: float
    ixy: float
    ixz: float
    iyy: float
    iyz: float
    izz: float

    def as_tuple(self) -> tuple[float, float, float, float, float, float]:
        return (self.ixx, self.ixy, self.ixz, self.iyy, self.iyz, self.izz)

    def matrix(self) -> np.ndarray:
        return np.array([[self.ixx, self.ixy, self.ixz],
                         [self.ixy, self.iyy, self.iyz],
                         [self.ixz, self.iyz, self.izz]])

    def principal_moments(self) -> np.ndarray:
        """Eigenvalues of the tensor, ascending."""
        return np.linalg.eigvalsh(self.matrix())

    def is_physical(self, rtol: float = 1e-9) -> bool:
        """Positive definite and I_small + I_mid ≥ I_large (equality only for flat shapes)."""
        m = self.principal_moments()
        return bool(m[0] > 0.0 and m[0] + m[1] >= m[2] * (1.0 - rtol))


def _check(mass: float, **dims: float) -> None:
    bad = {k: v for k, v in {"mass": mass, **dims}.items() if not v > 0.0}
    if bad:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"inertia needs positive mass and dimensions, got {bad}",
                         "pass mass > 0 kg and sizes > 0 m")


def box_inertia(mass: float, size: tuple[float, float, float]) -> Inertia:
    """Solid box with edge lengths (x, y, z): I_xx = m (y² + z²) / 12, and cyclically."""
    x, y, z = size
    _check(mass, x=x, y=y, z=z)
    k = mass / 12.0
    return Inertia(k * (y * y + z * z), 0.0, 0.0, k * (x * x + z * z), 0.0, k * (x * x + y * y))


def cylinder_inertia(mass: float, radius: float, length: float, axis: Axis = "z") -> Inertia:
    """Solid cylinder: m r² / 2 about its axis, m (3 r² + h²) / 12 about the two diameters.

    `axis` is the cylinder's axis in the frame the tensor is written in: a wheel whose axle is the link's
    y axis gets axis="y", so the tensor stays diagonal with no inertial rotation."""
    _check(mass, radius=radius, length=length)
    axial = mass * radius * radius / 2.0
    diametral = mass * (3.0 * radius * radius + length * length) / 12.0
    moments = {a: (axial if a == axis else diametral) for a in ("x", "y", "z")}
    return Inertia(moments["x"], 0.0, 0.0, moments["y"], 0.0, moments["z"])


def sphere_inertia(mass: float, radius: float) -> Inertia:
    """Solid sphere: 2 m r² / 5 about every axis."""
    _check(mass, radius=radius)
    i = 0.4 * mass * radius * radius
    return Inertia(i, 0.0, 0.0, i, 0.0, i)
