"""Formations: slot geometry against closed forms, collision-free spawning, fleet commands (move, sync, home)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from fleet import ErrorCode, FleetConfig, FleetError, FleetService
from fleet.formations import assign_slots, formation_offsets, to_frame, to_world
from sim import Pose2D

PP = {"controller": {"type": "pure_pursuit"}}


def _pairwise(xy: np.ndarray) -> np.ndarray:
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    np.fill_diagonal(d, np.inf)
    return d


def _run_until_done(svc: FleetService, task_ids: list[str], limit_s: float) -> list[dict]:
    for _ in range(int(limit_s)):
        svc.advance(1.0)
        status = [svc.task_status(t) for t in task_ids]
        if all(s["state"] in ("succeeded", "failed", "canceled") for s in status):
            return status
    return [svc.task_status(t) for t in task_ids]


@pytest.mark.parametrize("n", [2, 3, 5, 8, 12])
def test_circle_slots_sit_on_the_chord_radius(n):
    s = 1.3
    off = formation_offsets("circle", n, s)
    radius = s / (2 * math.sin(math.pi / n))  # neighbours one chord `s` apart
    assert np.allclose(np.hypot(*off.T), radius)
    ang = np.sort(np.arctan2(off[:, 1], off[:, 0]))
    gaps = np.diff(np.append(ang, ang[0] + 2 * math.pi))
    assert np.allclose(2 * radius * np.sin(gaps / 2), s)
    assert np.allclose(off.mean(axis=0), 0.0, atol=1e-12)


def test_grid_line_column_and_wedge_have_the_spacing():
    grid = formation_offsets("grid", 9, 1.5)
    assert np.allclose(_pairwise(grid).min(axis=1), 1.5)  # every slot's nearest neighbour at the spacing
    assert np.allclose(np.ptp(grid, axis=0), [3.0, 3.0])  # a 3 × 3 block
    line = formation_offsets("line", 4, 2.0)
    assert np.allclose(line[:, 0], 0.0) and np.allclose(np.sort(line[:, 1]), [-3, -1, 1, 3])
    column = formation_offsets("column", 3, 1.0)
    assert np.allclose(column[:, 1], 0.0) and np.allclose(np.sort(column[:, 0]), [-1, 0, 1])
    wedge = formation_offsets("wedge", 5, 1.0)
    arm = wedge[[0, 1, 3]]  # apex and the left arm: consecutive slots 1 m apart, at 45° behind
    assert np.allclose(np.hypot(*np.diff(arm, axis=0).T), 1.0)
    assert np.allclose(np.diff(arm, axis=0)[:, 0], -math.sqrt(0.5))


def test_to_frame_inverts_to_world():
    off = formation_offsets("wedge", 6, 1.4)
    centre = Pose2D(1.0, -2.0, 0.7)
    assert np.allclose(to_frame(to_world(off, centre), centre), off)


def _squared_travel(cur: np.ndarray, slots: np.ndarray, perm) -> float:
    return float(((cur - slots[list(perm)]) ** 2).sum())


def test_slot_assignment_matches_brute_force():
    rng = np.random.default_rng(4)
    for _ in range(5):
        cur, slots = rng.uniform(-5, 5, (6, 2)), rng.uniform(-5, 5, (6, 2))
        best = min(_squared_travel(cur, slots, p) for p in itertools.permutations(range(6)))
        assert _squared_travel(cur, slots, assign_slots(cur, slots)) == pytest.approx(best)


def test_spawn_fleet_grid_is_where_the_closed_form_says_and_collision_free():
    with FleetService(FleetConfig(world="empty", seed=2)) as svc:
        out = svc.spawn_fleet(9, "grid", Pose2D(0.5, -0.5, math.pi / 2), spacing=1.5, prefix="g")
        assert out["robots"] == [f"g{k}" for k in range(1, 10)]
        xy = np.array([[svc.robot(r).pose.x, svc.robot(r).pose.y] for r in out["robots"]])
        expect = to_world(formation_offsets("grid", 9, 1.5), Pose2D(0.5, -0.5, math.pi / 2))
        assert np.allclose(xy, expect, atol=1e-6)
        assert _pairwise(xy).min() == pytest.approx(1.5)
        svc.advance(0.5)
        assert not svc.snapshot.in_collision.any()
        with pytest.raises(FleetError) as err:  # the same slots again: they overlap the first fleet
            svc.spawn_fleet(4, "circle", Pose2D(0.5, -0.5, 0), spacing=1.5)
        assert err.value.code is ErrorCode.COLLISION and "g" in err.value.message


def test_random_spawn_keeps_its_separation_in_free_space():
    with FleetService(FleetConfig(world="robot_arena", seed=5)) as svc:
        out = svc.spawn_fleet(12, "random", spacing=1.2)
        xy = np.array([[p["x"], p["y"]] for p in out["poses"].values()])
        assert _pairwise(xy).min() >= 1.2
        dist, _ = svc.static_clearance().query(xy)
        assert (dist > svc.world.robot_spec("robot1").footprint_radius).all()  # footprint clear of obstacles
        svc.advance(0.5)
        assert not svc.snapshot.in_collision.any()


def test_bad_formations_fail_with_reasons():
    with FleetService(FleetConfig(world="robot_arena")) as svc:
        with pytest.raises(FleetError, match="known formations: line, column, grid, circle, wedge, random"):
            svc.spawn_fleet(3, "blob")
        with pytest.raises(FleetError, match="minimum separation"):
            svc.spawn_fleet(3, "line", Pose2D(-3, 3, 0), spacing=0.5)
        with pytest.raises(FleetError) as err:  # (0, 0) is inside the arena's central obstacle
            svc.spawn_fleet(4, "grid", Pose2D(0, 0, 0), spacing=1.0)
        assert err.value.code is ErrorCode.COLLISION and "not in free space" in err.value.message
        assert svc.robot_names() == []  # nothing half-spawned


def test_fleet_move_keeps_the_formation():
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP)) as svc:
        svc.spawn_fleet(4, "grid", Pose2D(-2.5, -2.5, 0), spacing=1.5)
        target = Pose2D(2.0, 1.5, math.pi / 2)
        out = svc.fleet_command("move", target=target)
        status = _run_until_done(svc, list(out["tasks"].values()), 90)
        assert all(s["state"] == "succeeded" for s in status)
        xy = np.array([[svc.robot(r).pose.x, svc.robot(r).pose.y] for r in out["robots"]])
        got = to_frame(xy, target)  # the shape about the target, in the formation frame
        want = formation_offsets("grid", 4, 1.5)
        perm = assign_slots(got, want)
        assert np.abs(got - want[perm]).max() < 0.25  # within the go-to tolerance of each slot
        assert svc.snapshot.in_collision.sum() == 0


def test_sync_makes_everyone_wait_for_the_slowest():
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP)) as svc:
        for k, y in enumerate((-2.0, 0.0, 2.0)):
            svc.spawn_robot(f"r{k}", Pose2D(-4.0, y, 0.0))
        legs = [svc.navigate(f"r{k}", Pose2D(-4.0 + d, y, 0.0))["id"]
                for k, (d, y) in enumerate(((1.0, -2.0), (3.0, 0.0), (6.0, 2.0)))]
        sync = svc.fleet_command("sync", ["r0", "r1", "r2"])
        status = _run_until_done(svc, list(sync["tasks"].values()), 60)
        arrivals = [svc.task_status(t)["finished"] for t in legs]
        released = [s["finished"] for s in status]
        assert all(s["state"] == "succeeded" for s in status)
        assert min(released) >= max(arrivals)  # nobody goes on before the slowest has arrived...
        assert max(released) - min(released) <= 0.1 + 1e-9  # ...then all within one control period
        assert max(arrivals) - min(arrivals) > 3.0  # and the fast ones really waited


def test_return_home_and_stop():
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP)) as svc:
        svc.spawn_fleet(2, "line", Pose2D(-3, 0, 0), spacing=1.5)
        homes = {r: svc.robot(r).pose for r in svc.robot_names()}
        out = svc.fleet_command("move", target=Pose2D(1.0, 0.0, 0.0))
        _run_until_done(svc, list(out["tasks"].values()), 40)
        back = svc.fleet_command("return_home")
        status = _run_until_done(svc, list(back["tasks"].values()), 40)
        assert all(s["state"] == "succeeded" for s in status)
        for r, home in homes.items():
            assert svc.robot(r).pose.distance_to(home) < 0.2
        again = svc.fleet_command("move", target=Pose2D(2.0, 2.0, 0.0))
        svc.advance(1.0)
        stop = svc.fleet_command("stop", ["robot1"])
        assert stop["robots"] == ["robot1"]
        assert svc.task_status(again["tasks"]["robot1"])["state"] == "canceled"
        assert svc.task_status(again["tasks"]["robot2"])["state"] == "active"
        with pytest.raises(FleetError, match="known robots: robot1, robot2"):
            svc.fleet_command("stop", ["nobody"])
        with pytest.raises(FleetError, match="commands: move, stop, formation, sync, return_home"):
            svc.fleet_command("dance")


def test_formation_change_reshapes_the_group_where_it_stands():
    with FleetService(FleetConfig(world="empty", seed=1, navigation=PP)) as svc:
        svc.spawn_fleet(4, "line", Pose2D(0.0, 0.0, 0.0), spacing=1.5)
        out = svc.fleet_command("formation", formation="circle", spacing=2.0)
        status = _run_until_done(svc, list(out["tasks"].values()), 40)
        assert all(s["state"] == "succeeded" for s in status)
        xy = np.array([[svc.robot(r).pose.x, svc.robot(r).pose.y] for r in out["robots"]])
        radius = 2.0 / (2 * math.sin(math.pi / 4))  # about the line's centroid, the origin
        assert np.abs(np.hypot(*xy.T) - radius).max() < 0.2
        assert svc.formations[-1].kind == "circle"
