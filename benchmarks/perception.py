"""Perception benchmark: every figure next to its baseline or ground truth, measured in this run.

  detection   recall / precision over camera frames through robot_arena.world, against the world's
              geometry (visual surfaces sampled, visibility by ray casting, width by projection)
  ekf         pose error of the odometry+IMU EKF vs wheel odometry alone vs ground truth, 100 m drive
  health      sim time from an injected sensor dropout (world.set_sensor_fault) to the alert
  imu_bias    estimated vs injected IMU bias (stationary 2 s window)
  lidar       lidar mounting offset from scans at known poses vs the spec's truth

Run: .venv/bin/python benchmarks/perception.py [--quick] [--fidelity kinematic|dynamic]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from sim import FleetError, Pose2D, Pose3D, RobotSpec, World
from sim.perception import (
    EkfConfig,
    SensorHealthMonitor,
    detect_objects,
    estimate_imu_bias,
    estimate_lidar_offset,
    intrinsics_of,
    make_ekf,
    map_outline,
)
from sim.perception.projection import inverse_transform_points, project
from sim.types import Box, CameraImage, Cylinder, Geometry, ImuReading, OdometryReading, Sphere

ARENA = Path(__file__).resolve().parent.parent / "configs" / "worlds" / "robot_arena.world"
MIN_WIDTH_PX = 10
MATCH_DIST = 0.25  # m: a detection's 3D position must lie this close to its model's surface


# ---- detection ground truth -------------------------------------------------------------------------

def surface_samples(g: Geometry, pose: Pose3D, step: float = 0.05, cap: int = 40) -> np.ndarray:
    """Points on a primitive's surface in the world (boxes: face grids; cylinders: side and caps)."""
    if isinstance(g, Box):
        pts = []
        for axis in range(3):
            u, v = [a for a in range(3) if a != axis]
            nu = min(cap, max(2, math.ceil(g.size[u] / step)))
            nv = min(cap, max(2, math.ceil(g.size[v] / step)))
            gu, gv = np.meshgrid(np.linspace(-0.5, 0.5, nu) * g.size[u], np.linspace(-0.5, 0.5, nv) * g.size[v])
            for sign in (-1.0, 1.0):
                p = np.zeros((gu.size, 3))
                p[:, axis], p[:, u], p[:, v] = sign * g.size[axis] / 2, gu.ravel(), gv.ravel()
                pts.append(p)
        local = np.concatenate(pts)
    elif isinstance(g, Cylinder):
        na = min(4 * cap, max(16, math.ceil(2 * math.pi * g.radius / step)))
        nz = min(cap, max(2, math.ceil(g.length / step)))
        a, z = np.meshgrid(np.linspace(0, 2 * math.pi, na, endpoint=False), np.linspace(-0.5, 0.5, nz) * g.length)
        side = np.column_stack([g.radius * np.cos(a.ravel()), g.radius * np.sin(a.ravel()), z.ravel()])
        cap_pts = np.column_stack([0.5 * g.radius * np.cos(a[0]), 0.5 * g.radius * np.sin(a[0]),
                                   np.full(na, g.length / 2)])
        local = np.concatenate([side, cap_pts])
    elif isinstance(g, Sphere):
        n = min(4 * cap * cap, max(50, math.ceil(4 * math.pi * g.radius ** 2 / step ** 2)))
        k = np.arange(n) + 0.5
        phi, th = np.arccos(1 - 2 * k / n), math.pi * (1 + 5 ** 0.5) * k
        local = g.radius * np.column_stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)])
    else:
        return np.zeros((0, 3))
    m = pose.matrix()
    return local @ m[:3, :3].T + m[:3, 3]


def model_samples(world: World, exclude: set[str]) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for model in world.description.models:
        if model.name in exclude:
            continue
        pts = [surface_samples(v.geometry, model.pose.compose(link.pose).compose(v.pose))
               for link in model.links for v in link.visuals]
        pts = [p for p in pts if len(p)]
        if pts:
            out[model.name] = np.concatenate(pts)
    return out


def visible_models(world: World, image: CameraImage, samples: dict[str, np.ndarray]) -> dict[str, float]:
    """Ground truth: model → visible width in px, from samples that project into the image and that a
    ray from the camera reaches first (models without collision geometry cannot be checked: skipped)."""
    k = intrinsics_of(image)
    eye = np.array(image.camera_pose.position)
    out: dict[str, float] = {}
    for name, pts in samples.items():
        uv, depth = project(inverse_transform_points(image.camera_pose, pts), k)
        inside = (depth > image.near) & (uv[:, 0] >= -0.5) & (uv[:, 0] < k.width - 0.5) \
            & (uv[:, 1] >= -0.5) & (uv[:, 1] < k.height - 0.5)
        if not inside.any():
            continue
        p = pts[inside]
        d = p - eye
        dist = np.linalg.norm(d, axis=1)
        ends = eye + d * ((dist + 0.02) / dist)[:, None]  # 2 cm past the surface point
        frac, uids = world.cast_rays(np.repeat(eye[None], len(p), axis=0), ends)
        hit_dist = frac * (dist + 0.02)
        ok = np.array([world.body_label(int(u))[0] == name for u in uids]) & (hit_dist >= dist - 0.03)
        if ok.any():
            u = uv[inside][ok, 0]
            out[name] = float(u.max() - u.min())
    return out


def tour_poses(world: World, robot: str, spacing: float, headings: int) -> list[Pose2D]:
    xmin, ymin, xmax, ymax = world.description.bounds(-0.6)
    xmin, ymin, xmax, ymax = max(xmin, -5.5), max(ymin, -5.5), min(xmax, 5.5), min(ymax, 5.5)
    poses = []
    for x in np.arange(xmin, xmax + 1e-9, spacing):
        for y in np.arange(ymin, ymax + 1e-9, spacing):
            for h in range(headings):
                pose = Pose2D(float(x), float(y), 2 * math.pi * h / headings + 0.3)
                try:
                    world.set_robot_pose(robot, pose)
                except FleetError:
                    continue  # inside an obstacle
                poses.append(pose)
    return poses


def bench_detection(quick: bool) -> dict[str, Any]:
    world = World.from_sdf(ARENA, seed=1)
    world.spawn_robot("r1", Pose2D(-5, -5, 0))
    samples = model_samples(world, {"ground_plane", "r1"})
    poses = tour_poses(world, "r1", 3.0 if quick else 1.5, 2 if quick else 4)
    expected = found = detections = correct = 0
    misses: list[str] = []
    phantoms: list[str] = []
    t0 = time.perf_counter()
    for pose in poses:
        world.set_robot_pose("r1", pose)
        image = world.render_camera("r1")
        truth = visible_models(world, image, samples)
        dets = detect_objects(image, world.body_label, exclude=("ground_plane", "r1"))
        seen = {d.label for d in dets}
        for name, width in truth.items():
            if width > MIN_WIDTH_PX:
                expected += 1
                found += name in seen
                if name not in seen:
                    misses.append(f"{name}@({pose.x:.1f},{pose.y:.1f},{pose.yaw:.1f}) {width:.0f}px")
        for d in dets:
            detections += 1
            pts = samples.get(d.model)
            ok = pts is not None and d.position is not None \
                and float(np.min(np.linalg.norm(pts - np.array(d.position), axis=1))) < MATCH_DIST
            correct += ok
            if not ok:
                phantoms.append(f"{d.label}@({pose.x:.1f},{pose.y:.1f}) {d.pixel_count}px")
    elapsed = time.perf_counter() - t0
    world.close()
    return {"frames": len(poses), "expected": expected, "found": found, "detections": detections,
            "correct": correct, "misses": misses[:5], "phantoms": phantoms[:5],
            "recall": found / max(expected, 1), "precision": correct / max(detections, 1),
            "ms_per_frame": 1e3 * elapsed / max(len(poses), 1)}


# ---- EKF on a long drive ----------------------------------------------------------------------------

def bench_ekf(quick: bool, fidelity: str) -> dict[str, Any]:
    spec = RobotSpec.model_validate({"sensors": {"imu": {"gyro_bias": [0.0, 0.0, 0.01]}}})
    world = World(seed=3, fidelity=fidelity)  # type: ignore[arg-type]
    world.spawn_robot("r1", Pose2D(0, 0, 0), spec=spec)
    imu: list[ImuReading] = []
    unsub = world.subscribe(lambda r: imu.append(r) if isinstance(r, ImuReading) else None, kinds=("imu",))
    world.run_for(2.0)  # stand still: calibrate the gyro
    unsub()
    bias = estimate_imu_bias(imu)
    ekf = make_ekf(EkfConfig(gyro_std=0.005), Pose2D(0, 0, 0), world.time)
    rows: list[tuple[Pose2D, Pose2D, Pose2D]] = []  # truth, odometry, ekf at each odometry tick

    def on_reading(r: Any) -> None:
        if isinstance(r, ImuReading):
            ekf.update_imu(r, gyro_bias=bias.gyro[2])
        elif isinstance(r, OdometryReading):
            ekf.update_odometry(r)
            rows.append((world.robot_pose("r1"), r.pose, ekf.state.pose))

    world.subscribe(on_reading, kinds=("imu", "odom"))
    duration = 25.0 if quick else 100.0
    t_start = world.time
    travelled, last = 0.0, world.robot_pose("r1")
    t0 = time.perf_counter()
    while world.time - t_start < duration:
        t = world.time - t_start
        world.set_cmd_vel("r1", 1.0, 0.4 * math.sin(0.15 * t))
        world.run_for(0.1)
        now = world.robot_pose("r1")
        travelled += now.distance_to(last)
        last = now
    elapsed = time.perf_counter() - t0
    world.close()
    truth = np.array([[p.x, p.y] for p, _, _ in rows])
    odo = np.array([[p.x, p.y] for _, p, _ in rows])
    est = np.array([[p.x, p.y] for _, _, p in rows])
    err = lambda a: np.linalg.norm(a - truth, axis=1)  # noqa: E731
    yaw_err = lambda i: float(np.degrees(abs(math.remainder(rows[-1][i].yaw - rows[-1][0].yaw, 2 * math.pi))))  # noqa: E731
    return {"fidelity": fidelity, "travelled": travelled, "bias_est": bias.gyro[2],
            "odom_final": float(err(odo)[-1]), "ekf_final": float(err(est)[-1]),
            "odom_rms": float(np.sqrt(np.mean(err(odo) ** 2))), "ekf_rms": float(np.sqrt(np.mean(err(est) ** 2))),
            "odom_yaw_deg": yaw_err(1), "ekf_yaw_deg": yaw_err(2), "wall_s": elapsed}


# ---- health, IMU bias, lidar offset -------------------------------------------------------------------

def bench_health() -> dict[str, Any]:
    world = World.from_sdf(ARENA, seed=4)  # walls for the lidar to see while the robot stands still
    world.spawn_robot("r1", Pose2D(-5, -5, 0))
    mon = SensorHealthMonitor()
    mon.add_robot("r1", world.robot_spec("r1"))
    mon.attach(world)
    world.run_for(3.0)
    out: dict[str, Any] = {"healthy_alerts": [a.kind for a in mon.alerts(world.time)]}
    for sensor, stream in (("lidar", "r1/scan"), ("imu", "r1/imu"), ("odom", "r1/odom")):
        t_fault = world.time
        world.set_sensor_fault("r1", sensor, dropout=True)
        while world.time - t_fault < 2.0:
            world.step()
            if any(a.kind == "dropout" for a in mon.report(world.time, stream)[stream].alerts):
                break
        out[f"{sensor}_delay"] = world.time - t_fault
        world.set_sensor_fault("r1", sensor)
        world.run_for(2.5)  # recover, and let the gap leave the window
    t_fault = world.time
    world.set_sensor_fault("r1", "lidar", noise_scale=4.0)
    while world.time - t_fault < 3.0:
        world.step()
        if any(a.kind == "noise" for a in mon.report(world.time, "r1/scan")["r1/scan"].alerts):
            break
    out["noise_delay"] = world.time - t_fault
    out["noise_std"] = mon.report(world.time + 1.0, "r1/scan")["r1/scan"].noise_std
    world.close()
    return out


def bench_imu_bias() -> dict[str, Any]:
    accel, gyro = (0.05, -0.03, 0.08), (0.004, -0.006, 0.01)
    spec = RobotSpec.model_validate({"sensors": {"imu": {"accel_bias": list(accel), "gyro_bias": list(gyro)}}})
    world = World(seed=5)
    world.spawn_robot("r1", Pose2D(0, 0, 0), spec=spec)
    imu: list[ImuReading] = []
    world.subscribe(lambda r: imu.append(r) if isinstance(r, ImuReading) else None, kinds=("imu",))
    world.run_for(2.0)
    world.close()
    est = estimate_imu_bias(imu)
    rel = [abs(e - t) / abs(t) for e, t in zip((*est.accel, *est.gyro), (*accel, *gyro), strict=True)]
    return {"samples": est.samples, "truth": (*accel, *gyro), "estimate": (*est.accel, *est.gyro),
            "max_rel_error": max(rel)}


def bench_lidar_offset(quick: bool) -> dict[str, Any]:
    spec = RobotSpec.model_validate({"mast": {"x_offset": 0.1}})
    world = World.from_sdf(ARENA, seed=6)
    world.spawn_robot("r1", Pose2D(-5, -5, 0), spec=spec)
    poses = tour_poses(world, "r1", 3.0, 2)[: 4 if quick else 10]
    scans = []
    for pose in poses:
        world.set_robot_pose("r1", pose)
        world.run_for(0.11)  # one fresh 10 Hz scan at this pose
        scan = world.latest_scan("r1")
        if scan is not None:
            scans.append((scan, world.robot_pose("r1")))
    pts, normals = map_outline(world.description, spec.lidar_height, exclude=("ground_plane",))
    world.close()
    truth = Pose2D(0.1, 0.0, 0.0)
    est = estimate_lidar_offset(scans, pts, normals, truth=truth)
    return {"scans": est.scans, "estimate": est.offset.as_tuple(), "error_xy": est.error_xy,
            "error_yaw_deg": math.degrees(est.error_yaw or 0.0), "rms": est.rms_residual,
            "uncalibrated_error": math.hypot(truth.x, truth.y)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer frames, a 25 m drive")
    ap.add_argument("--fidelity", default="kinematic", choices=("kinematic", "dynamic"))
    a = ap.parse_args()
    d = bench_detection(a.quick)
    print(f"detection  {d['frames']} frames of robot_arena: recall {d['recall']:.3f} ({d['found']}/{d['expected']}"
          f" models wider than {MIN_WIDTH_PX} px), precision {d['precision']:.3f} ({d['correct']}/{d['detections']}),"
          f" {d['ms_per_frame']:.0f} ms/frame incl. render + truth")
    for m in d["misses"]:
        print(f"           miss: {m}")
    for m in d["phantoms"]:
        print(f"           phantom: {m}")
    e = bench_ekf(a.quick, a.fidelity)
    print(f"ekf        {e['fidelity']}, {e['travelled']:.1f} m driven: position error final / RMS — wheel odometry "
          f"{e['odom_final']:.3f} / {e['odom_rms']:.3f} m, EKF odom+IMU {e['ekf_final']:.3f} / {e['ekf_rms']:.3f} m;"
          f" final yaw error odom {e['odom_yaw_deg']:.2f}°, EKF {e['ekf_yaw_deg']:.2f}°"
          f" (gyro bias 0.01 est {e['bias_est']:.5f}); {e['wall_s']:.1f} s wall")
    h = bench_health()
    print(f"health     dropout flagged after (sim s; target ≤ 1.0, threshold 3 periods): lidar {h['lidar_delay']:.2f}"
          f" (0.30), imu {h['imu_delay']:.2f} (0.03), odom {h['odom_delay']:.2f} (0.06); lidar noise ×4 flagged after"
          f" {h['noise_delay']:.2f} s (σ est {h['noise_std']:.4f} vs nominal 0.01 → 0.04);"
          f" alerts while healthy: {h['healthy_alerts'] or 'none'}")
    b = bench_imu_bias()
    print(f"imu_bias   {b['samples']} samples: truth {np.round(b['truth'], 4).tolist()} estimate "
          f"{np.round(b['estimate'], 4).tolist()}, max relative error {100 * b['max_rel_error']:.1f} % (target 10 %)")
    lo = bench_lidar_offset(a.quick)
    print(f"lidar      offset from {lo['scans']} scans: estimate {np.round(lo['estimate'], 4).tolist()} vs truth"
          f" [0.1, 0, 0]: error {1e3 * lo['error_xy']:.1f} mm, {lo['error_yaw_deg']:.3f}° (uncalibrated:"
          f" {1e3 * lo['uncalibrated_error']:.0f} mm), residual RMS {1e3 * lo['rms']:.1f} mm")


if __name__ == "__main__":
    main()
