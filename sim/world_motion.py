"""Per-step motion of the world's robots: wheel motors of dynamic robots, unicycle integration of kinematic ones,
and the physics health check. Kept apart from sim/world.py so World reads as the recipe of a step."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

from sim.drive import integrate_unicycle, wheel_speeds
from sim.errors import ErrorCode, FleetError
from sim.kinematic_collisions import resolve_kinematic_collisions

if TYPE_CHECKING:
    from sim.world import World

from sim.models import MAX_SPEED  # m/s: any body faster than this is a physics explosion, not motion


def drive_dynamic_robots(world: World) -> None:
    rows = world._dynamic_rows()
    if rows.size == 0:
        return
    f = world.table.f
    wl, wr = wheel_speeds(f["sp_v"][rows], f["sp_w"][rows], f["wheel_radius"][rows], f["wheel_sep"][rows])
    for i, left, right in zip(rows.tolist(), wl.tolist(), wr.tolist(), strict=True):
        name = world.table.names[i]
        body = world.bodies[name]
        torque = world.specs[name].wheels.max_torque
        joints, n_left = [*body.drive_left, *body.drive_right], len(body.drive_left)
        p.setJointMotorControlArray(body.uid, joints, p.VELOCITY_CONTROL,
                                    targetVelocities=[left] * n_left + [right] * (len(joints) - n_left),
                                    forces=[torque] * len(joints), physicsClientId=world.client)


def move_kinematic_robots(world: World) -> None:
    f, kin = world.table.f, world.table.b["kinematic"]
    rows = np.flatnonzero(kin)
    if rows.size == 0:
        return
    x0, y0, th0 = f["x"][rows], f["y"][rows], f["yaw"][rows]
    v, w = f["sp_v"][rows], f["sp_w"][rows]
    f["v"][rows], f["w"][rows] = v, w
    moving = (np.abs(v) > 0) | (np.abs(w) > 0)
    nx, ny, nth = integrate_unicycle(x0, y0, th0, v, w, world.dt)
    f["x"][rows], f["y"][rows], f["yaw"][rows] = nx, ny, nth
    blocked = resolve_kinematic_collisions(world, rows[moving], (x0[moving], y0[moving], th0[moving]))
    # True wheel rotation of the motion actually made (blocked robots did not move).
    ds = np.hypot(f["x"][rows] - x0, f["y"][rows] - y0) * np.sign(v)
    dth = (f["yaw"][rows] - th0 + np.pi) % (2 * np.pi) - np.pi
    sep, r = f["wheel_sep"][rows], f["wheel_radius"][rows]
    f["wheel_l"][rows] += (ds - dth * sep / 2) / r
    f["wheel_r"][rows] += (ds + dth * sep / 2) / r
    if blocked.size:  # a blocked robot stops: its drive starts again from rest
        for col in ("v", "w", "sp_v", "sp_w"):
            f[col][blocked] = 0.0


def check_physics_health(world: World) -> None:
    f = world.table.f
    bad = ~(np.isfinite(f["x"]) & np.isfinite(f["y"]) & np.isfinite(f["yaw"]) & np.isfinite(f["v"])
            & (np.abs(f["v"]) < MAX_SPEED))
    culprit = world.table.names[int(np.flatnonzero(bad)[0])] if bad.any() else world.models.unstable_model()
    if culprit is not None:
        world.faulted = FleetError(ErrorCode.PHYSICS_UNSTABLE,
                                      f"body '{culprit}' has a NaN or exploding state at t={world._time:.3f} s",
                                      "restore a snapshot or reset; check masses, inertias and overlaps")
        raise world.faulted
