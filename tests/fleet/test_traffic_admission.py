"""Dispatch admission (fleet/traffic/admission.py): the AIMD limit and the FIFO of held goals in closed form, and
on the corridor world (8 robots swap rooms through a one-lane corridor, test_traffic_corridor.py) with at most 2
robots admitted: the limit is never exceeded, held goals start in the order they were given, and the robots held
idle in the rooms never block the ones PIBT drives through them (every swap completes, no overlap)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import enable_traffic
from fleet.traffic.admission import Admission, Held, layer_admission
from tests.fleet.test_traffic_corridor import STARTS, closest_pair_gap, corridor_world, spawn_swap_fleet


def test_admit_never_exceeds_the_limit_and_keeps_fifo_order() -> None:
    adm = Admission(limit=3)
    assert not adm.must_hold(2) and adm.must_hold(3)
    for k in range(5):
        adm.hold(f"r{k}", float(k), 0.0, now=float(k))
    assert adm.must_hold(0)  # others wait already: a new goal queues behind them
    adm.hold("r1", 9.0, 9.0, now=7.0)  # a newer goal replaces the held one in place
    assert [h.robot for h in adm.admit(active=2, now=10.0)] == ["r0"]
    assert adm.admit(active=3, now=10.0) == []
    out = adm.admit(active=0, now=12.0)
    assert [h.robot for h in out] == ["r1", "r2", "r3"] and (out[0].x, out[0].since) == (9.0, 1.0)
    assert adm.stats["longest_hold_s"] == 11.0 and adm.stats["admitted"] == 4
    adm.drop("r4")
    assert not adm.queue and not adm.held("r4")


def test_aimd_limit_in_closed_form() -> None:
    adm = Admission(period_s=2.0, stalled_share=0.1, decrease=0.7, grow=1, cooldown_s=10.0)
    adm.update(0.0, active=100, stalled=10)  # 10 % is not above the share: no limit while nothing binds
    assert adm.limit == math.inf
    adm.update(1.0, active=100, stalled=50)  # within the period: no step
    assert adm.limit == math.inf
    adm.update(2.0, active=100, stalled=11)
    assert adm.limit == 70  # floor(0.7 · min(inf, 100))
    adm.update(4.0, active=90, stalled=80)  # the cut has not drained yet: held, not cut again
    assert adm.limit == 70
    adm.update(6.0, active=70, stalled=20)  # drained, but within the cool-down (the signal lags): not yet
    assert adm.limit == 70
    adm.update(12.0, active=70, stalled=20)
    assert adm.limit == 49
    adm.queue.append(Held("r", 0.0, 0.0, 6.0))
    adm.update(14.0, active=49, stalled=0)
    adm.update(16.0, active=50, stalled=0)
    assert adm.limit == 51  # additive increase while it binds
    adm.queue.clear()
    adm.update(20.0, active=20, stalled=0)
    assert adm.limit == math.inf  # not binding, nobody held: lifted
    assert adm.stats["decreases"] == 2 and adm.stats["lowest_limit"] == 49


def test_park_grows_by_one_robot_per_signal_lag() -> None:
    for free_below, after in ((0.0, 42), (60.0, 61)):  # half of 60 stalled, nothing held
        a = Admission(stalled_share=0.05, limit=60, free_below=free_below)
        a.update(0.0, active=60, stalled=30)
        assert a.limit == after  # cut to 0.7 · 60; within free_below never cut (it binds: + 1)
    adm = Admission(period_s=2.0, stalled_share=0.05, grow_s=10.0, limit=60, free_below=60)
    adm.queue.append(Held("r", 0.0, 0.0, 0.0))
    for now in range(0, 31, 2):  # binds all along (a goal held), nobody stalled
        adm.update(float(now), active=int(adm.limit), stalled=0)
    assert adm.limit == 64  # at t = 0, 10, 20 and 30 only (aimd, grow_s 0: every period, 76)
    adm.update(32.0, active=64, stalled=4)  # 4 > 5 % of 64: multiplicative decrease as before
    assert adm.limit == 44


def test_start_limit_never_below_the_robots_the_stalled_share_needs() -> None:
    """park's start limit is 1/8 of the free cells but never below 1 / 5 % = 20 robots (aimd: 1 / 20 % = 5), so on
    a small map (the corridor world's 28 cells) a fleet of up to 20 robots is never held nor cut while it flows."""
    small, large = layer_admission("park", 10.0, 28), layer_admission("park", 10.0, 965)
    assert small is not None and large is not None
    assert small.limit == small.free_below == 20.0
    assert large.limit == large.free_below == 965 / 8
    aimd = layer_admission("aimd", 10.0, 28)
    assert aimd is not None and aimd.limit == 5.0 and aimd.free_below == 0.0
    assert layer_admission("off", 10.0, 28) is None
    assert not small.must_hold(19) and small.must_hold(20)
    small.update(0.0, active=8, stalled=8)  # all 8 in a wait, nothing held: within the floor, not cut but lifted
    assert small.limit == math.inf and small.stats["decreases"] == 0


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("admission")


def test_held_robots_idle_in_the_rooms_never_block_the_admitted_ones(tmp: Path) -> None:
    with FleetService(FleetConfig(world=str(corridor_world(tmp)), seed=0, physics_hz=20.0, control_hz=10.0)) as svc:
        starts = STARTS
        spawn_swap_fleet(svc)
        tm = enable_traffic(svc, cell=1.0, speed=0.6, stall_s=10.0, admission="aimd")
        adm = tm.admission
        assert adm is not None
        adm.limit, adm.period_s = 2, math.inf  # a fixed limit: the AIMD step is tested above
        adm._next = math.inf
        admitted: list[str] = []
        admit = adm.admit
        adm.admit = lambda active, now: [admitted.append(h.robot) or h for h in admit(active, now)]  # type: ignore[method-assign, func-returns-value]

        def go_all() -> None:
            for k, (x, y) in enumerate(starts):
                tm.add(f"r{k}")
                tm.go(f"r{k}", -x, y)  # to the mirror cell in the other room, occupied by a held robot

        svc.call(go_all)
        assert [tm.held(f"r{k}") for k in range(8)] == [False] * 2 + [True] * 6
        most, worst = [0], [np.inf]

        def check() -> None:
            most[0] = max(most[0], int(np.count_nonzero(tm.pending)))
            worst[0] = min(worst[0], closest_pair_gap(svc, tm.radius))

        svc.step_listeners.append(check)
        t = 0.0
        while t < 600.0 and (tm.stats["reached"] < 8 or tm.active_count() or adm.queue):
            svc.advance(5.0)
            t += 5.0
        assert most[0] <= 2  # the limit
        assert admitted == [f"r{k}" for k in range(2, 8)]  # FIFO: in the order the goals were given
        assert tm.stats["reached"] >= 8 and not adm.queue, tm.describe()
        xy = np.array([[svc.world.robot_pose(f"r{k}").x, svc.world.robot_pose(f"r{k}").y] for k in range(8)])
        assert np.allclose(xy, [(-x, y) for x, y in starts], atol=0.15)  # every robot at its mirror cell
        assert worst[0] > 0.0
