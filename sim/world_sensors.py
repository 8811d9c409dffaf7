"""Sensor sampling of a World, split out of sim/world.py: each physics step the due lidars (one batched ray
cast), IMU and odometry, contacts of dynamic robots at the bumper rate; cameras on request; fault injection.
Functions over the World (they read and write its table, readings and listeners), not a class of their own."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sim.errors import ErrorCode, FleetError, unknown_name
from sim.sensors import camera
from sim.sensors.inertial import imu_reading, odometry_reading, sample_imu, sample_odometry
from sim.sensors.lidar import cast_scans
from sim.types import CameraImage
from sim.world_types import SensorFault

if TYPE_CHECKING:
    from sim.world import World

EPS = 1e-9  # s: a sensor due within this of now samples now (sim time is step_count × dt, not accumulated)


def sample_sensors(w: World) -> None:
    """The due sensors of this step, in a fixed order (lidar, IMU, odometry, contacts) so runs repeat."""
    t, now = w.table, w.time
    if not len(t):
        return
    f, b = t.f, t.b
    due = (f["next_lidar"] <= now + EPS) & (f["lidar_period"] > 0)
    if due.any():
        f["next_lidar"][due] += f["lidar_period"][due] * np.ceil((now + EPS - f["next_lidar"][due])
                                                               / f["lidar_period"][due]).clip(min=1)
        rows = np.flatnonzero(due & ~b["lidar_dropout"])
        for scan in cast_scans(t, rows, w._lidar_cfg, w.cast_rays, w.rng, now):
            w._scans[scan.robot] = scan
            w._emit("scan", scan)
    for kind, sampler in (("imu", sample_imu), ("odom", sample_odometry)):
        nxt, per = f[f"next_{kind}"], f[f"{kind}_period"]
        due = (nxt <= now + EPS) & (per > 0)
        if due.any():
            nxt[due] += per[due] * np.ceil((now + EPS - nxt[due]) / per[due]).clip(min=1)
            sampler(t, due & ~b[f"{kind}_dropout"], w.rng, now)
            if w._wants(kind):
                for i in np.flatnonzero(due & ~b[f"{kind}_dropout"]):
                    w._emit(kind, imu_reading(t, int(i)) if kind == "imu" else odometry_reading(t, int(i)))
    if w.step_count % w._contact_every == 0:
        collect_dynamic_contacts(w)


def collect_dynamic_contacts(w: World) -> None:
    from sim.robot_spawn import dynamic_contacts

    rows = w._dynamic_rows()
    if rows.size == 0:
        return
    found = dynamic_contacts(w, set(w.table.body[rows].tolist()))
    for i in rows:
        name = w.table.names[i]
        w._contacts[name] = tuple(found.get(int(w.table.body[i]), ()))
        w.table.b["in_collision"][i] = bool(w._contacts[name])
    if w._wants("contact"):
        for name in w.table.names:
            w._emit("contact", w.latest_contacts(name))


def render_camera(w: World, name: str, *, rgb: bool, depth: bool, segmentation: bool, which: str) -> CameraImage:
    """The robot's RGB camera (`which="rgb"`, 640×480) or depth camera (`which="depth"`, 320×240)."""
    i = w._row(name)
    spec = w.specs[name]
    if w._faults.get((name, "camera"), SensorFault()).dropout:
        raise FleetError(ErrorCode.UNSUPPORTED, f"camera of '{name}' is failed (injected dropout)")
    f = w.table.f
    pose = camera.camera_world_pose(float(f["x"][i]), float(f["y"][i]), float(f["yaw"][i]),
                                    camera.camera_mount(spec))
    if which == "depth":
        d = spec.sensors.depth
        return camera.render(w.client, name, w.time, pose, d.width, d.height, d.fov_deg, 0.05,
                             d.range_max * 1.5, rgb=rgb, depth=depth, segmentation=segmentation,
                             depth_range=(d.range_min, d.range_max), depth_noise=d.noise_std, rng=w.rng)
    c = spec.sensors.camera
    return camera.render(w.client, name, w.time, pose, c.width, c.height, c.fov_deg, c.near, c.far,
                         rgb=rgb, depth=depth, segmentation=segmentation, depth_range=None, depth_noise=0.0,
                         rng=w.rng)


def set_sensor_fault(w: World, robot: str, sensor: str, *, dropout: bool, noise_scale: float) -> None:
    """Failure injection: make a sensor stop publishing (dropout) or get noisier (noise_scale × σ)."""
    i = w._row(robot)
    valid = ("lidar", "imu", "odom", "camera")
    if sensor not in valid:
        raise unknown_name("sensor", sensor, valid, ErrorCode.INVALID_ARGUMENT)
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"noise_scale must be ≥ 0, got {noise_scale}")
    w._faults[(robot, sensor)] = SensorFault(dropout, noise_scale)
    if sensor != "camera":
        w.table.b[f"{sensor}_dropout"][i] = dropout
        w.table.f[f"{sensor}_noise_scale"][i] = noise_scale
