"""Drive models. Both obey the same velocity and acceleration limits.

kinematic: exact unicycle integration of the acceleration-limited twist, for all kinematic robots at once.
dynamic: the same limited twist turned into wheel speeds for PyBullet velocity motors (see sim/world.py).
"""

from __future__ import annotations

import numpy as np

from sim.robot_table import RobotTable


def limit_twist(t: RobotTable, dt: float) -> None:
    """Move each robot's setpoint (sp_v, sp_w) toward its command by at most (max_a, max_alpha)·dt.

    The setpoint is separate from the measured twist (v, w): feeding a dynamic robot's measured twist back
    into the ramp would leave it forever short of its command."""
    f = t.f
    f["sp_v"] += np.clip(f["cmd_v"] - f["sp_v"], -f["max_a"] * dt, f["max_a"] * dt)
    f["sp_w"] += np.clip(f["cmd_w"] - f["sp_w"], -f["max_alpha"] * dt, f["max_alpha"] * dt)


def integrate_unicycle(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, v: np.ndarray, w: np.ndarray,
                       dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact integration for constant (v, w) over dt: arcs of radius v/w, straight lines where w ≈ 0."""
    th1 = yaw + w * dt
    small = np.abs(w) < 1e-9
    w_safe = np.where(small, 1.0, w)
    nx = np.where(small, x + v * dt * np.cos(yaw), x + v / w_safe * (np.sin(th1) - np.sin(yaw)))
    ny = np.where(small, y + v * dt * np.sin(yaw), y - v / w_safe * (np.cos(th1) - np.cos(yaw)))
    return nx, ny, (th1 + np.pi) % (2 * np.pi) - np.pi


def wheel_speeds(v: np.ndarray | float, w: np.ndarray | float, radius: np.ndarray | float,
                 separation: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Left and right wheel angular velocities (rad/s) for body twist (v, w)."""
    vl = (np.asarray(v) - np.asarray(w) * np.asarray(separation) / 2) / np.asarray(radius)
    vr = (np.asarray(v) + np.asarray(w) * np.asarray(separation) / 2) / np.asarray(radius)
    return vl, vr
