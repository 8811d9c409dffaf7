"""Vectorised SE(2) helpers on (x, y, yaw) arrays; sim.transforms has the scalar versions."""

from __future__ import annotations

import math

import numpy as np

from sim.transforms import wrap_angles

PoseTuple = tuple[float, float, float]


def rotation(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]])


def transform_points(pose: PoseTuple, points: np.ndarray) -> np.ndarray:
    """Points (n, 2) given in the frame `pose`, expressed in pose's parent frame."""
    x, y, yaw = pose
    return points @ rotation(yaw).T + np.array([x, y])


def to_matrix(pose: PoseTuple) -> np.ndarray:
    """3×3 homogeneous matrix of a planar pose."""
    m = np.eye(3)
    m[:2, :2] = rotation(pose[2])
    m[:2, 2] = pose[:2]
    return m


def from_matrix(m: np.ndarray) -> PoseTuple:
    """Planar pose of a 3×3 or 4×4 homogeneous matrix (a 4×4 is projected onto the xy-plane)."""
    return (float(m[0, -1]), float(m[1, -1]), math.atan2(float(m[1, 0]), float(m[0, 0])))


def to_matrix4(pose: PoseTuple) -> np.ndarray:
    """4×4 homogeneous matrix (z = 0, no roll/pitch), as KISS-ICP uses."""
    m = np.eye(4)
    m[:2, :2] = rotation(pose[2])
    m[:2, 3] = pose[:2]
    return m


def compose_many(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a ⊕ b for (n, 3) pose arrays."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([
        a[:, 0] + c * b[:, 0] - s * b[:, 1],
        a[:, 1] + s * b[:, 0] + c * b[:, 1],
        wrap_angles(a[:, 2] + b[:, 2]),
    ])


def between_many(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a⁻¹ ⊕ b for (n, 3) pose arrays."""
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, wrap_angles(b[:, 2] - a[:, 2])])


def adjoint(pose: PoseTuple) -> np.ndarray:
    """Adjoint of SE(2) in (x, y, yaw) tangent order: moves a covariance between frames."""
    x, y, yaw = pose
    a = np.eye(3)
    a[:2, :2] = rotation(yaw)
    a[0, 2] = y
    a[1, 2] = -x
    return a
