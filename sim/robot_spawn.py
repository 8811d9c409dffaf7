"""Adding robots to a World, teleporting them, and reading dynamic robots back from PyBullet."""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

from sim.contact_query import hull_columns
from sim.errors import ErrorCode, FleetError
from sim.kinematic_collisions import RawContact, overlaps
from sim.robot_body import dynamic_robot, kinematic_proxy
from sim.robot_spec import RobotSpec
from sim.sensors.lidar import LidarConfig
from sim.transforms import rpy_to_quat
from sim.types import Fidelity, Pose2D

if TYPE_CHECKING:
    from sim.world import World

NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]{0,63}$")


def spawn_robot(world: World, name: str, pose: Pose2D, spec: RobotSpec, fidelity: Fidelity, *,
                check_collision: bool) -> str:
    if not NAME_RE.match(name):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"invalid robot name '{name}'",
                         "use a letter then letters, digits, '_' or '-' (at most 64)")
    if world.table.has(name) or name in world.models.names():
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"name '{name}' is already in use", "pick another name")
    if fidelity not in ("kinematic", "dynamic"):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown fidelity '{fidelity}'", "use kinematic or dynamic")
    body = kinematic_proxy(world.client, spec) if fidelity == "kinematic" else dynamic_robot(world.client, spec)
    s = spec.sensors
    now = world.time

    def period(enabled: bool, hz: float) -> float:
        return 1.0 / hz if enabled else 0.0

    floats = {
        "x": pose.x, "y": pose.y, "yaw": pose.yaw,
        "max_v": spec.limits.max_linear, "max_w": spec.limits.max_angular,
        "max_a": spec.limits.max_linear_accel, "max_alpha": spec.limits.max_angular_accel,
        # REP-105: the odom frame starts where the robot starts, so map→odom is the identity at spawn.
        "odom_x": pose.x, "odom_y": pose.y, "odom_yaw": pose.yaw,
        "wheel_radius": spec.wheels.radius, "wheel_sep": spec.wheels.separation, "radius": spec.footprint_radius,
        "lidar_period": period(s.lidar.enabled, s.lidar.rate_hz), "imu_period": period(s.imu.enabled, s.imu.rate_hz),
        "odom_period": period(s.odometry.enabled, s.odometry.rate_hz),
        "next_lidar": now + period(s.lidar.enabled, s.lidar.rate_hz)
        - lidar_phase(world, period(s.lidar.enabled, s.lidar.rate_hz)),
        "next_imu": now + period(s.imu.enabled, s.imu.rate_hz),
        "next_odom": now + period(s.odometry.enabled, s.odometry.rate_hz),
        "imu_stamp": now, "odom_stamp": now,
        "lidar_noise_scale": 1.0, "imu_noise_scale": 1.0, "odom_noise_scale": 1.0,
        "lidar_noise_std": s.lidar.noise_std, "imu_accel_std": s.imu.accel_noise_std,
        "imu_gyro_std": s.imu.gyro_noise_std,
        "imu_bax": s.imu.accel_bias[0], "imu_bay": s.imu.accel_bias[1], "imu_baz": s.imu.accel_bias[2],
        "imu_bgx": s.imu.gyro_bias[0], "imu_bgy": s.imu.gyro_bias[1], "imu_bgz": s.imu.gyro_bias[2],
        "odom_slip_std": s.odometry.slip_std, "odom_radius_scale": 1.0 + s.odometry.wheel_radius_error,
    }
    if fidelity == "kinematic":  # created unrotated at the origin: its AABB now is its box in its own frame
        floats |= hull_columns(world.client, body.uid)
    row = world.table.add(name, body.uid, floats, {"kinematic": fidelity == "kinematic"})
    world.specs[name], world.bodies[name], world.fidelities[name] = spec, body, fidelity
    world._lidar_cfg.append(LidarConfig.from_spec(spec))
    world._sync_labels()
    try:
        place_robot(world, row, pose, check_collision=check_collision)
    except FleetError:
        world.remove_robot(name)
        raise
    return name


def lidar_phase(world: World, period: float) -> float:
    """How much earlier than one period after spawn a new robot's first scan comes (a whole number of physics
    steps, < one period), so the fleet's lidars are spread over the steps of a period instead of all being cast
    in one step: the step joins the phase slot (due step mod steps-per-period) that the fewest lidars use now,
    the earliest-ending slot on ties. It reads only the robot table, so the same spawns give the same phases
    (and scans keep exactly their rate in sim time). `world.lidar_phases == "aligned"` keeps every first scan
    one period after spawn (the old behaviour; benchmarks compare both)."""
    n = int(period / world.dt + 1e-9)  # whole physics steps per lidar period
    if period <= 0 or n < 2 or world.lidar_phases == "aligned":
        return 0.0
    f = world.table.f
    has = f["lidar_period"] > 0
    used = np.bincount(np.rint(f["next_lidar"][has] / world.dt).astype(np.int64) % n, minlength=n)
    last = round((world.time + period) / world.dt)  # the step the first scan is due without a phase
    k = np.arange(n)
    return float(int(np.argmin(used[(last - k) % n])) * world.dt)


def place_robot(world: World, row: int, pose: Pose2D, *, check_collision: bool) -> None:
    """Teleport to `pose` at rest; refuse (and stay put) if it overlaps anything."""
    t, c = world.table, world.client
    name = t.names[row]
    body = world.bodies[name]
    old = (float(t.f["x"][row]), float(t.f["y"][row]), float(t.f["yaw"][row]))
    z = 0.0  # every robot body's base frame is base_link, on the floor under the axle centre (sim.urdf_process)
    p.resetBasePositionAndOrientation(body.uid, (pose.x, pose.y, z), rpy_to_quat(0, 0, pose.yaw), physicsClientId=c)
    p.resetBaseVelocity(body.uid, (0, 0, 0), (0, 0, 0), physicsClientId=c)
    t.f["x"][row], t.f["y"][row], t.f["yaw"][row] = pose.x, pose.y, pose.yaw  # the broadphase reads the table
    if check_collision:
        hit = overlaps(world, body.uid)
        if hit:
            t.f["x"][row], t.f["y"][row], t.f["yaw"][row] = old
            p.resetBasePositionAndOrientation(body.uid, (old[0], old[1], z), rpy_to_quat(0, 0, old[2]),
                                              physicsClientId=c)
            raise FleetError(ErrorCode.COLLISION, f"pose ({pose.x:.3f}, {pose.y:.3f}) of '{name}' overlaps {hit}",
                             "choose a free pose (see the occupancy map)")
    for col in ("v", "w", "cmd_v", "cmd_w", "sp_v", "sp_w", "prev_v", "prev_w"):
        t.f[col][row] = 0.0


def read_dynamic_states(world: World, rows: np.ndarray) -> None:
    """Copy dynamic robots' poses, body twists and wheel angles from PyBullet into the table, gathering into
    lists and writing each column once."""
    t, c = world.table, world.client
    n = rows.size
    x, y, yaw, v, w, wl, wr = (np.empty(n) for _ in range(7))
    for k, i in enumerate(rows.tolist()):
        uid = int(t.body[i])
        body = world.bodies[t.names[i]]
        pos, (qx, qy, qz, qw) = p.getBasePositionAndOrientation(uid, physicsClientId=c)
        lin, ang = p.getBaseVelocity(uid, physicsClientId=c)
        th = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        js = p.getJointStates(uid, [body.left_wheel, body.right_wheel], physicsClientId=c)
        x[k], y[k], yaw[k] = pos[0], pos[1], th
        v[k], w[k] = lin[0] * math.cos(th) + lin[1] * math.sin(th), ang[2]
        wl[k], wr[k] = js[0][0], js[1][0]
    v[~(np.isfinite(x) & np.isfinite(y) & np.isfinite(v))] = np.nan  # the health check names these robots
    f = t.f
    f["x"][rows], f["y"][rows], f["yaw"][rows], f["v"][rows], f["w"][rows] = x, y, yaw, v, w
    f["wheel_l"][rows], f["wheel_r"][rows] = wl, wr


def dynamic_contacts(world: World, uids: set[int]) -> dict[int, list[RawContact]]:
    """Contacts of dynamic robots with anything but the ground (wheels on the floor are not bumps), from one
    global contact query grouped by body (a per-robot query costs time proportional to the fleet)."""
    out: dict[int, list[RawContact]] = {}
    ground = world._ground_uids
    for ct in p.getContactPoints(physicsClientId=world.client):
        a, b = ct[1], ct[2]
        if a in ground or b in ground or a == b:
            continue
        if a in uids:
            out.setdefault(a, []).append((int(b), (ct[5][0], ct[5][1], ct[5][2]), float(ct[9])))
        if b in uids:
            out.setdefault(b, []).append((int(a), (ct[6][0], ct[6][1], ct[6][2]), float(ct[9])))
    return out
