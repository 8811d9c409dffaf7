"""A false loop closure injected into a sim run (sim.World, warehouse.world) leaves ATE within tolerance."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim import World
from sim.transforms import wrap_angle
from sim.types import LidarScan, Pose2D
from slam.metrics import trajectory_errors
from slam.pipeline import SlamPipeline
from slam.types import LoopClosure, LoopClosureConfig, SlamConfig

Run = tuple[list[LidarScan], list[Pose2D], np.ndarray]  # scans, wheel odometry, ground truth
WORLD = Path(__file__).resolve().parents[2] / "configs" / "worlds" / "warehouse.world"
# A loop in the open south hall, back past the start: ≈ 20 m, 25 s of sim time.
ROUTE = [(-10.5, -16.5), (-10.5, -18.6), (-17.0, -18.6), (-17.0, -16.5), (-13.0, -16.5)]
START = Pose2D(-16.0, -16.5, 0.0)


@pytest.fixture(scope="module")
def run() -> Run:
    world = World.from_sdf(WORLD, seed=3, fidelity="kinematic", physics_hz=50)  # 10 Hz control
    world.spawn_robot("r1", START)
    scans, odom, truth = [], [], []
    last = -1.0
    for wx, wy in ROUTE:
        while (d := math.hypot(wx - world.robot_pose("r1").x, wy - world.robot_pose("r1").y)) > 0.15:
            p = world.robot_pose("r1")
            err = wrap_angle(math.atan2(wy - p.y, wx - p.x) - p.yaw)
            world.set_cmd_vel("r1", 0.8 * max(0.0, math.cos(err)) ** 4 * min(1.0, d / 0.5 + 0.3),
                              max(-1.2, min(1.2, 2.5 * err)))
            for _ in range(5):
                world.step()
                s = world.latest_scan("r1")
                if s is not None and s.stamp != last:
                    last = s.stamp
                    o = world.latest_odometry("r1")
                    assert o is not None
                    scans.append(s)
                    odom.append(o.pose)
                    truth.append(world.robot_pose("r1").as_tuple())
    world.close()
    return scans, odom, np.array(truth)


def _slam(run: Run, config: SlamConfig | None = None, inject: bool = False
          ) -> tuple[SlamPipeline, float, LoopClosure | None]:
    scans, odom, truth = run
    slam = SlamPipeline(config, initial_pose=Pose2D(*truth[0]))
    closure = None
    for k, (s, o) in enumerate(zip(scans, odom, strict=True)):
        slam.process_scan(s, o)
        if inject and k == len(scans) // 2:
            # Perceptual aliasing: "the latest keyframe is where keyframe 1 was" — really metres apart.
            latest = len(slam.keyframes) - 1
            closure = slam.add_loop_closure(1, latest, Pose2D(0.2, 0.0, 0.0), np.diag([1e-4, 1e-4, 1e-5]))
    _, est = slam.trajectory()
    return slam, trajectory_errors(est, truth).ate_rmse, closure


def test_clean_run_is_accurate(run: Run) -> None:
    slam, ate, _ = _slam(run)
    assert ate < 0.03
    assert slam.status().loop_closures_accepted >= 1  # it came back past the start


def test_false_loop_closure_is_rejected_and_ate_stays_within_tolerance(run: Run) -> None:
    _, clean, _ = _slam(run)
    slam, ate, closure = _slam(run, inject=True)
    assert closure is not None and not closure.accepted
    assert slam.status().rejection_reasons.get(closure.reason, 0) >= 1
    assert ate < 0.03 and abs(ate - clean) < 0.005


def test_without_the_safeguards_the_same_closure_wrecks_the_map(run: Run) -> None:
    """The checks above are what protect the map: with no gate, no residual test and no robust kernel,
    the injected closure is accepted and the trajectory is bent by metres."""
    off = LoopClosureConfig(gate_chi2=1e12, residual_chi2=1e12, robust_kernel="none")
    _, ate, closure = _slam(run, SlamConfig(loop_closure=off), inject=True)
    assert closure is not None and closure.accepted
    assert ate > 0.3
