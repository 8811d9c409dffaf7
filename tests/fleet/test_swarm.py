"""Swarm behaviours: consensus against its closed form, rendezvous, flocking, the registry and takeovers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import ErrorCode, FleetConfig, FleetError, FleetService
from fleet.swarm import BehaviourConfig, behaviour_names, consensus_velocity, register_behaviour, to_unicycle
from sim import Pose2D


def _scattered(svc: FleetService, xy: list[tuple[float, float]], seed: int) -> list[str]:
    rng = np.random.default_rng(seed)
    for k, (x, y) in enumerate(xy):
        svc.spawn_robot(f"s{k}", Pose2D(x, y, float(rng.uniform(-math.pi, math.pi))))
    return [f"s{k}" for k in range(len(xy))]


def test_consensus_on_the_complete_graph_matches_the_closed_form():
    """ṗ = −kLp: the centroid c stays put and p_i(t) − c = e^{−k n t} (p_i(0) − c)."""
    rng = np.random.default_rng(0)
    p0 = rng.uniform(-5, 5, (5, 2))
    k, n, dt, steps = 0.1, 5, 0.001, 3000
    p = p0.copy()
    for _ in range(steps):
        u = consensus_velocity(p, k)
        assert np.abs(u.sum(axis=0)).max() < 1e-12  # Σ velocities = 0
        p = p + dt * u
    c = p0.mean(axis=0)
    expect = c + (p0 - c) * (1 - k * n * dt) ** steps  # forward Euler of the exponential
    assert np.allclose(p, expect, atol=1e-9)
    assert np.allclose(p, c + (p0 - c) * math.exp(-k * n * dt * steps), atol=1e-3)


def test_consensus_on_a_disc_graph_keeps_the_centroid():
    p = np.array([[0.0, 0.0], [1.0, 0.0], [2.5, 0.0], [9.0, 9.0]])
    u = consensus_velocity(p, 0.5, comm_radius=2.0)
    assert np.allclose(u.sum(axis=0), 0.0)
    assert np.allclose(u[3], 0.0)  # out of range of everyone: no neighbours
    assert np.allclose(u[0], 0.5 * np.array([1.0, 0.0]))


def test_unicycle_mapping_reproduces_the_planar_velocity_of_the_tracked_point():
    yaw = np.array([0.3, -2.0])
    u = np.array([[0.2, 0.1], [-0.1, 0.25]])
    cmd = to_unicycle(u, yaw, np.array([1.0, 1.0]), np.array([5.0, 5.0]), offset=0.15)
    h = np.column_stack([np.cos(yaw), np.sin(yaw)])
    hp = np.column_stack([-h[:, 1], h[:, 0]])
    assert np.allclose(cmd[:, :1] * h + 0.15 * cmd[:, 1:] * hp, u)


def test_rendezvous_converges_to_the_initial_centroid():
    with FleetService(FleetConfig(world="empty", seed=3)) as svc:
        robots = _scattered(svc, [(-3.0, -2.5), (3.0, -2.0), (2.5, 3.0), (-2.0, 2.5)], seed=1)
        b = svc.start_behaviour("rendezvous", robots)
        svc.advance(20.0)
        st = svc.behaviour_status(b["id"], history=True)
        m = st["metrics"]
        assert st["initial_metrics"]["spread_m"] > 3.5
        assert m["centroid_drift_m"] < 0.05  # the consensus invariant, on the real robots
        assert st["converged"] and 0 < st["convergence_time_s"] < 20
        assert 0.6 < m["spread_m"] < 1.3  # packed around the centroid, one separation apart
        assert svc.control.stats["collisions"] == 0
        assert st["history"][0]["t"] == 0.0 and len(st["history"]) >= 18


def test_flocking_improves_cohesion_and_alignment():
    with FleetService(FleetConfig(world="empty", seed=4)) as svc:
        robots = _scattered(svc, [(-3.5, -3.5), (-1.0, -3.0), (2.0, -3.5), (-3.0, 0.5), (0.5, 0.0), (3.0, 1.0)],
                            seed=2)
        b = svc.start_behaviour("flocking", robots, {"speed": 0.3})
        first = svc.behaviour_status(b["id"])["initial_metrics"]
        svc.advance(20.0)
        m = svc.behaviour_status(b["id"])["metrics"]
        assert first["alignment"] < 0.6 and m["alignment"] > 0.9
        assert m["cohesion_radius_m"] < 0.8 * first["cohesion_radius_m"]
        assert m["min_gap_m"] > 0 and svc.control.stats["collisions"] == 0


def test_registry_errors_and_takeovers():
    assert {"coverage", "flocking", "formation", "leader_follower", "rendezvous"} <= set(behaviour_names())
    with pytest.raises(FleetError, match="already registered"):
        register_behaviour("flocking", BehaviourConfig)(object)
    with FleetService(FleetConfig(world="empty")) as svc:
        robots = _scattered(svc, [(-2.0, 0.0), (2.0, 0.0), (0.0, 2.0)], seed=0)
        with pytest.raises(FleetError, match="known behaviours: coverage, flocking"):
            svc.start_behaviour("swarming", robots)
        with pytest.raises(FleetError, match="needs at least 2 robots"):
            svc.start_behaviour("rendezvous", robots[:1])
        with pytest.raises(FleetError) as err:
            svc.start_behaviour("rendezvous", robots, {"gian": 1.0})
        assert err.value.code is ErrorCode.INVALID_ARGUMENT and "gian" in err.value.message
        with pytest.raises(FleetError, match="known robots"):
            svc.start_behaviour("rendezvous", ["s0", "ghost"])
        b = svc.start_behaviour("rendezvous", robots)
        assert svc.snapshot.controller == ("idle",) * 3  # published at the next tick
        svc.advance(0.2)
        assert set(svc.snapshot.controller) == {f"behaviour:{b['id']}"}
        svc.drive("s0", 0.1, 0.0)  # a manual takeover: s0 leaves, two robots go on
        st = svc.behaviour_status(b["id"])
        assert st["robots"] == ["s1", "s2"] and st["state"] == "running"
        svc.drive("s1", 0.1, 0.0)  # one left: too few for a rendezvous
        st = svc.behaviour_status(b["id"])
        assert st["state"] == "stopped" and "too few" in st["reason"]
        b2 = svc.start_behaviour("flocking", ["s1", "s2"])
        assert svc.stop_behaviour(b2["id"])["state"] == "stopped"
        assert [x["id"] for x in svc.behaviour_status()] == [b["id"], b2["id"]]
        with pytest.raises(FleetError, match="no behaviour 'b999'"):
            svc.behaviour_status("b999")
