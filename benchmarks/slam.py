"""SLAM benchmark: one robot drives a ≥ 150 m route through configs/worlds/warehouse.world (sim.World,
kinematic fidelity, the sim's lidar σ = 1 cm and wheel slip), then the recorded scans are run through:

  wheel odometry alone | KISS-ICP alone | full SLAM (KISS-ICP + GTSAM pose graph + loop closures)

and compared with ground truth (ATE after SE(2) alignment, RPE). Also: processing speed as a multiple
of real time, map IoU against planning's rasteriser at lidar height, localisation RMSE in the SLAM map
(saved and re-loaded as PGM + YAML) and the time to recover from a kidnapping.

    .venv/bin/python benchmarks/slam.py [--quick] [--seed N]
"""

from __future__ import annotations

import sys
from pathlib import Path

# Run as a script, this file's folder comes first on sys.path and its name would shadow the slam package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

import argparse  # noqa: E402
import math  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from planning.grid import OccupancyGrid  # noqa: E402
from planning.map_io import load_map  # noqa: E402
from planning.rasterize import rasterize_world  # noqa: E402
from sim import World  # noqa: E402
from sim.transforms import se2_between, se2_compose, wrap_angle  # noqa: E402
from sim.types import LidarScan, Pose2D  # noqa: E402
from slam import KissOdometry, Localizer, SlamConfig, SlamPipeline, map_iou, trajectory_errors  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
WORLD = ROOT / "configs" / "worlds" / "warehouse.world"
START = Pose2D(-16.0, -16.5, math.pi / 2)  # spawn_1
# Serpentine through three aisles and the north hall, back south down the west cross-aisle (crossing
# every aisle driven before), then home through the south hall: ≈ 215 m, several revisits.
ROUTE = [(-18.6, -16.5), (-18.6, -10.9), (18.6, -10.9), (18.6, -2.1), (-18.6, -2.1), (-18.6, 6.7), (18.6, 6.7),
         (18.6, 16.5), (-6.3, 16.5), (-6.3, -16.5), (-16.0, -16.5)]
QUICK_ROUTE = [(-18.6, -16.5), (-18.6, -10.9), (-6.3, -10.9), (-6.3, -16.5), (-16.0, -16.5)]
KIDNAP_TO = Pose2D(-6.3, -13.5, -math.pi / 2)  # in the cross-aisle: mapped by both routes


@dataclass
class Recording:
    scans: list[LidarScan]
    odom: list[Pose2D]  # wheel odometry at each scan
    truth: np.ndarray  # (n, 3) ground-truth pose at each scan
    duration: float  # s of sim time
    length: float  # m driven


def drive(world: World, robot: str, route: list[tuple[float, float]], speed: float = 0.8) -> Recording:
    """Follow the route's waypoints (turn towards the next one, then drive), recording every scan with
    the wheel odometry and the ground-truth pose at that moment."""
    scans: list[LidarScan] = []
    odom: list[Pose2D] = []
    truth: list[tuple[float, float, float]] = []
    t0, last_stamp, length = world.time, -1.0, 0.0
    prev = world.robot_pose(robot)
    for k, (wx, wy) in enumerate(route):
        while True:
            pose = world.robot_pose(robot)
            dx, dy = wx - pose.x, wy - pose.y
            dist = math.hypot(dx, dy)
            if dist < 0.15 or (k == len(route) - 1 and dist < 0.3):
                break
            err = wrap_angle(math.atan2(dy, dx) - pose.yaw)
            w = max(-1.2, min(1.2, 2.5 * err))
            v = speed * max(0.0, math.cos(err)) ** 4 * min(1.0, dist / 0.5 + 0.3)
            world.set_cmd_vel(robot, v, w)
            for _ in range(5):  # 20 Hz control at 100 Hz physics
                world.step()
                scan = world.latest_scan(robot)
                if scan is not None and scan.stamp != last_stamp:
                    last_stamp = scan.stamp
                    reading = world.latest_odometry(robot)
                    now = world.robot_pose(robot)
                    scans.append(scan)
                    odom.append(reading.pose if reading is not None else Pose2D())
                    truth.append(now.as_tuple())
                    length += now.distance_to(prev)
                    prev = now
    world.set_cmd_vel(robot, 0.0, 0.0)
    return Recording(scans, odom, np.array(truth), world.time - t0, length)


def record(route: list[tuple[float, float]], seed: int) -> Recording:
    world = World.from_sdf(WORLD, seed=seed, fidelity="kinematic", physics_hz=100)
    try:
        world.spawn_robot("r1", START)
        return drive(world, "r1", route)
    finally:
        world.close()


def record_kidnap(seed: int) -> tuple[Recording, int]:
    """Drive the first half of the quick route, teleport the robot further along it (its wheel odometry
    does not notice), drive on. Returns the recording and the index of the first scan after the kidnap."""
    world = World.from_sdf(WORLD, seed=seed, fidelity="kinematic", physics_hz=100)
    try:
        world.spawn_robot("r1", START)
        a = drive(world, "r1", QUICK_ROUTE[:3])
        world.set_robot_pose("r1", KIDNAP_TO)
        b = drive(world, "r1", QUICK_ROUTE[3:])
    finally:
        world.close()
    rec = Recording(a.scans + b.scans, a.odom + b.odom, np.vstack([a.truth, b.truth]), a.duration + b.duration,
                    a.length + b.length)
    return rec, len(a.scans)


# ---- the three estimators ------------------------------------------------------------------------------


# Every estimator starts from the ground-truth pose at the first scan: the robot knows where it was spawned.


def wheel_only(rec: Recording) -> np.ndarray:
    o0, start = rec.odom[0].as_tuple(), tuple(rec.truth[0])
    return np.array([se2_compose(start, se2_between(o0, o.as_tuple())) for o in rec.odom])


def kiss_only(rec: Recording, **kw: Any) -> tuple[np.ndarray, float]:
    od = KissOdometry(**kw)
    start = tuple(rec.truth[0])
    t = time.perf_counter()
    out, prev = [], None
    delta: tuple[float, float, float] | None
    for scan, o in zip(rec.scans, rec.odom, strict=True):
        delta = se2_between(prev.as_tuple(), o.as_tuple()) if prev is not None else None
        prev = o
        out.append(se2_compose(start, od.register(scan.points(), delta).pose.as_tuple()))
    return np.array(out), time.perf_counter() - t


def full_slam(rec: Recording, config: SlamConfig | None = None) -> tuple[SlamPipeline, np.ndarray, float]:
    slam = SlamPipeline(config, robot="r1", initial_pose=Pose2D(*rec.truth[0]))
    t = time.perf_counter()
    for scan, o in zip(rec.scans, rec.odom, strict=True):
        slam.process_scan(scan, o)
    _, est = slam.trajectory()
    return slam, est, time.perf_counter() - t


# ---- localisation ---------------------------------------------------------------------------------------


def localise(grid: OccupancyGrid, rec: Recording, kidnap_at: int, seed: int
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """Run the localiser over the recording from a 0.2 m / 0.1 rad wrong start; returns its estimates,
    the dead-reckoning (wheel odometry) baseline from the same start, and the wall time."""
    loc = Localizer(grid, seed=seed)
    x, y, yaw = rec.truth[0]
    start = Pose2D(x + 0.15, y - 0.13, yaw + 0.1)
    loc.initialize(start)
    t = time.perf_counter()
    est = np.array([loc.update(s, o).pose.as_tuple() for s, o in zip(rec.scans, rec.odom, strict=True)])
    wall = time.perf_counter() - t
    o0 = rec.odom[0].as_tuple()
    dead = np.array([se2_compose(start.as_tuple(), se2_between(o0, o.as_tuple())) for o in rec.odom])
    return est, dead, wall


def recovery_time(err: np.ndarray, stamps: np.ndarray, kidnap_at: int, tol: float = 0.1, hold: int = 10) -> float:
    """Sim seconds from the kidnapping until the error stays below `tol` for `hold` scans (inf: never)."""
    ok = err[kidnap_at:] < tol
    for k in range(len(ok) - hold + 1):
        if ok[k:k + hold].all():
            return float(stamps[kidnap_at + k] - stamps[kidnap_at])
    return math.inf


# ---- report ---------------------------------------------------------------------------------------------


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="a 35 m route instead of the 215 m one")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    route = QUICK_ROUTE if args.quick else ROUTE

    t = time.perf_counter()
    rec = record(route, args.seed)
    print(f"drive: {rec.length:.1f} m in {rec.duration:.1f} s sim time, {len(rec.scans)} scans "
          f"(simulated in {time.perf_counter() - t:.1f} s)")

    wheel = trajectory_errors(wheel_only(rec), rec.truth)
    kiss_est, kiss_wall = kiss_only(rec)
    kiss = trajectory_errors(kiss_est, rec.truth)
    c0 = time.process_time()
    slam, slam_est, slam_wall = full_slam(rec)
    slam_cpu = time.process_time() - c0
    full = trajectory_errors(slam_est, rec.truth)
    st = slam.status()
    print("\ntrajectory (ATE after SE(2) alignment; RPE over 10 scans = 1 s)")
    print(f"{'estimator':<28}{'ATE RMSE':>10}{'ATE max':>10}{'RPE trans':>11}{'RPE rot':>10}")
    for name, e in (("wheel odometry (baseline)", wheel), ("KISS-ICP alone", kiss), ("full SLAM", full)):
        print(f"{name:<28}{e.ate_rmse * 100:>8.2f}cm{e.ate_max * 100:>8.2f}cm{e.rpe_trans_rmse * 100:>9.2f}cm"
              f"{math.degrees(e.rpe_rot_rmse):>8.3f}°")
    print(f"full SLAM vs KISS-ICP alone: {kiss.ate_rmse / full.ate_rmse:.1f}x lower ATE RMSE; "
          f"without alignment {trajectory_errors(slam_est, rec.truth, align=False).ate_rmse * 100:.2f} cm")
    print(f"keyframes {st.keyframes}, loop closures accepted {st.loop_closures_accepted}, "
          f"rejected {st.loop_closures_rejected} {st.rejection_reasons}")

    t = time.perf_counter()
    slam.map()
    render = time.perf_counter() - t
    n = len(rec.scans)
    print("\nspeed (sensor time / processing time)")
    print(f"KISS-ICP alone      {rec.duration / kiss_wall:7.1f}x real time ({kiss_wall / n * 1e3:.2f} ms/scan)")
    print(f"full SLAM           {rec.duration / slam_wall:7.1f}x real time ({slam_wall / n * 1e3:.2f} ms/scan,"
          f" CPU {slam_cpu / n * 1e3:.2f} ms/scan)")
    print(f"  + final map render {render:.2f} s → {rec.duration / (slam_wall + render):.1f}x real time overall")

    with tempfile.TemporaryDirectory() as tmp:
        loaded = load_map(slam.save_map(Path(tmp) / "warehouse_slam.yaml"))
    world = World.from_sdf(WORLD, seed=0)
    h = world.default_spec().lidar_height
    truth_grid = rasterize_world(world.description, resolution=loaded.resolution, slab=(h - 0.01, h + 0.01))
    world.close()
    iou1, iou0 = map_iou(loaded, truth_grid, 1), map_iou(loaded, truth_grid, 0)
    print(f"\nmap vs ground truth (planning rasteriser at lidar height {h:.2f} m, {loaded.resolution} m cells)")
    print(f"IoU occupied {iou1.occupied:.3f} (±1 cell) / {iou0.occupied:.3f} (exact), free {iou1.free:.3f}, "
          f"mean {iou1.mean:.3f} (±1 cell); map knows {iou1.coverage:.0%} of the free floor")

    lrec, kidnap_at = record_kidnap(args.seed + 1)
    est, dead, wall = localise(loaded, lrec, kidnap_at, args.seed)
    err = np.hypot(*(est[:, :2] - lrec.truth[:, :2]).T)
    derr = np.hypot(*(dead[:, :2] - lrec.truth[:, :2]).T)
    stamps = np.array([s.stamp for s in lrec.scans])
    settle = 20  # the first 2 s: the filter converges from its wrong start
    rec_t = recovery_time(err, stamps, kidnap_at)
    after = kidnap_at + (round(rec_t * 10) + 10 if math.isfinite(rec_t) else len(err))
    track = np.concatenate([err[settle:kidnap_at], err[after:]])
    print(f"\nlocalisation in the saved SLAM map ({len(lrec.scans)} scans, kidnapped at scan {kidnap_at})")
    print(f"RMSE {np.sqrt(np.mean(track**2)) * 100:.2f} cm while tracking (dead reckoning from the same start, "
          f"before the kidnapping: {np.sqrt(np.mean(derr[settle:kidnap_at] ** 2)) * 100:.2f} cm); "
          f"{wall / len(lrec.scans) * 1e3:.1f} ms/scan")
    print(f"kidnapped-robot recovery: {rec_t:.1f} s of sim time until the error stays < 10 cm")


if __name__ == "__main__":
    main()
