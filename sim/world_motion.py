"""Per-step motion of the world's robots: wheel motors of dynamic robots, unicycle integration of kinematic ones,
the physics health check, and batched velocity commands. Kept apart from sim/world.py so World reads as the
recipe of a step."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pybullet as p
from numpy.typing import ArrayLike

from sim.drive import integrate_unicycle, wheel_speeds
from sim.errors import ErrorCode, FleetError, unknown_name
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


def set_cmd_vels(world: World, robots: Sequence[str] | np.ndarray, v: ArrayLike, w: ArrayLike) -> np.ndarray:
    """World.set_cmd_vels: validate everything first (a bad entry changes nothing), then one clamped write."""
    t = world.table
    if isinstance(robots, np.ndarray) and robots.dtype.kind in "iu":
        rows = robots.astype(np.int64, copy=False).ravel()
        bad = (rows < 0) | (rows >= len(t))
        if bad.any():
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot row {int(rows[bad][0])} is out of range",
                             f"rows index world.robot_names(): 0…{len(t) - 1}")
    else:
        index = t._index
        found = [index.get(n, -1) for n in robots]
        if -1 in found:
            raise unknown_name("robot", list(robots)[found.index(-1)], t.names, ErrorCode.UNKNOWN_ROBOT)
        rows = np.array(found, dtype=np.int64)
    try:
        vv, ww = (np.broadcast_to(np.asarray(a, dtype=float), rows.shape) for a in (v, w))
    except ValueError:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{rows.size} robots but {np.size(v)} v and {np.size(w)} w",
                         "pass one v and one w per robot (or one for all)") from None
    finite = np.isfinite(vv) & np.isfinite(ww)
    if not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"velocity of '{t.names[rows[k]]}' must be finite, "
                         f"got v={vv[k]}, w={ww[k]}")
    f = t.f
    max_v, max_w = f["max_v"][rows], f["max_w"][rows]
    av, aw = np.clip(vv, -max_v, max_v), np.clip(ww, -max_w, max_w)
    f["cmd_v"][rows], f["cmd_w"][rows] = av, aw
    return (av != vv) | (aw != ww)
