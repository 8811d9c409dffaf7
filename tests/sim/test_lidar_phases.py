"""Lidar phases (issue 17): a fleet's lidars are spread over the physics steps of their period, each robot's scans
still come at exactly its rate in sim time, and the phases depend only on the spawns (same seed, same scans)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from sim import LidarScan, Pose2D, World, default_robot_path, load_robot_spec
from sim.errors import FleetError
from sim.robot_spec import RobotSpec


def _spec(beams: int = 16, rate_hz: float = 10.0, noise: float = 0.01) -> RobotSpec:
    spec = load_robot_spec(default_robot_path())
    lidar = spec.sensors.lidar.model_copy(update={"beams": beams, "rate_hz": rate_hz, "noise_std": noise})
    return spec.model_copy(update={"sensors": spec.sensors.model_copy(update={"lidar": lidar})})


def _fleet(n: int, phases: str = "spread", seed: int = 5, rate_hz: float = 10.0) -> tuple[World, list[LidarScan]]:
    w = World(physics_hz=100, seed=seed, lidar_phases=phases)
    spec = _spec(rate_hz=rate_hz)
    for i in range(n):
        w.spawn_robot(f"r{i}", Pose2D(2.0 * (i % 5), 2.0 * (i // 5), 0.1 * i), spec=spec)
    scans: list[LidarScan] = []
    w.subscribe(lambda s: scans.append(s) if isinstance(s, LidarScan) else None, kinds=("scan",))
    return w, scans


def _steps_by_robot(scans: list[LidarScan]) -> dict[str, list[int]]:
    out: dict[str, list[int]] = {}
    for s in scans:
        out.setdefault(s.robot, []).append(round(s.stamp * 100))
    return out


def test_scans_keep_their_rate_and_the_fleet_is_spread_over_the_period() -> None:
    w, scans = _fleet(25)
    with w:
        w.run_for(2.0)
    steps = _steps_by_robot(scans)
    assert sorted(steps) == sorted(f"r{i}" for i in range(25))
    for robot, s in steps.items():
        assert np.all(np.diff(s) == 10), robot  # exactly 10 Hz in sim time: one scan every 10 physics steps
        assert 1 <= s[0] <= 10, robot  # the first scan within one period of the spawn
        assert len(s) in (20, 21) and s[-1] <= 200
    # 25 lidars over the 10 steps of a period: every step casts 2 or 3 (balanced), never the whole fleet
    per_step = Counter(k for s in steps.values() for k in s if k > 10)
    assert set(per_step.values()) <= {2, 3} and len({k % 10 for k in per_step}) == 10
    # the first robot keeps the old timing (first scan one period after spawn); the next ones come earlier
    assert steps["r0"][0] == 10 and steps["r1"][0] == 9 and steps["r9"][0] == 1 and steps["r10"][0] == 10


def test_aligned_phases_cast_every_lidar_in_the_same_step() -> None:
    w, scans = _fleet(12, phases="aligned")
    with w:
        w.run_for(1.0)
    assert {k for s in _steps_by_robot(scans).values() for k in s} == set(range(10, 101, 10))
    with pytest.raises(FleetError, match="lidar phase policy"):
        World(lidar_phases="random")


def test_a_robot_spawned_later_joins_the_least_used_step_and_keeps_its_rate() -> None:
    w, scans = _fleet(3)
    with w:
        w.run_for(0.37)
        w.spawn_robot("late", Pose2D(-3.0, -3.0, 0.0), spec=_spec())
        w.run_for(1.0)
    steps = _steps_by_robot(scans)
    used = {s[0] % 10 for r, s in steps.items() if r != "late"}  # r0, r1, r2 on steps ≡ 0, 9, 8 (mod 10)
    assert used == {0, 9, 8}
    late = steps["late"]
    # one period after the spawn (step 47, ≡ 7) is a free slot: it keeps the old timing
    assert late[0] == 47 and np.all(np.diff(late) == 10)


def test_same_spawns_same_phases_and_same_scans() -> None:
    a, sa = _fleet(15, seed=9)
    b, sb = _fleet(15, seed=9)
    with a, b:
        a.run_for(0.8)
        b.run_for(0.8)
    assert [(s.robot, s.stamp) for s in sa] == [(s.robot, s.stamp) for s in sb]
    assert all(np.array_equal(x.ranges, y.ranges) for x, y in zip(sa, sb, strict=True))


def test_slower_lidar_keeps_its_period_when_spread() -> None:
    w, scans = _fleet(8, rate_hz=4.0)  # 25 steps per period
    with w:
        w.run_for(3.0)
    for robot, s in _steps_by_robot(scans).items():
        assert np.all(np.diff(s) == 25), robot
        assert 1 <= s[0] <= 25
    assert len({s[0] for s in _steps_by_robot(scans).values()}) == 8  # eight different steps


def test_culling_robots_out_of_reach_changes_no_scan(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each step casts a few lidars and the closed-form robot pass tests each ray only against the robots it
    can reach (sim/raycast_robots.py _pairs): the scans are the ones testing every ray against every robot
    gives, neighbours included; and no Embree scene is built for the robots."""
    import sim.raycast_robots as rr

    def run() -> list[LidarScan]:
        w = World(physics_hz=100, seed=2)
        spec = _spec(beams=180, noise=0.0)
        for i in range(12):  # two clusters 30 m apart (beyond the 10 m range): each sees only its own
            w.spawn_robot(f"r{i}", Pose2D(1.5 * (i % 3) + 30.0 * (i // 6), 1.5 * (i // 3 % 2), 0.2 * i), spec=spec)
        for i in range(12):
            w.set_cmd_vel(f"r{i}", 0.2, 0.3 - 0.05 * i)
        scans: list[LidarScan] = []
        w.subscribe(lambda s: scans.append(s) if isinstance(s, LidarScan) else None, kinds=("scan",))
        with w:
            w.run_for(0.5)
            assert w.rays.embree._dynamic_scene((0.1, 0.7)) == []
        return scans

    culled = run()
    def every_pair(rg: rr.RayGroups, xy: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
        return np.repeat(np.arange(len(rg.order)), len(xy)), np.tile(np.arange(len(xy)), len(rg.order))

    monkeypatch.setattr(rr, "_pairs", every_pair)  # every ray against every robot
    whole = run()
    assert [(s.robot, s.stamp) for s in culled] == [(s.robot, s.stamp) for s in whole] and len(culled) == 60
    robot_hits = 0
    for a, b in zip(culled, whole, strict=True):
        assert a.hit_bodies is not None and b.hit_bodies is not None
        assert np.array_equal(a.hit_bodies, b.hit_bodies), a.robot
        assert np.allclose(a.ranges, b.ranges, rtol=0, atol=1e-9)
        robot_hits += int((a.hit_bodies >= 0).sum())
    assert robot_hits > 300  # the neighbours are in the scans (the empty world has nothing else to hit)
