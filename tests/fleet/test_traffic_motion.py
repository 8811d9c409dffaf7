"""Traffic layer, the motion profile (fleet/traffic/motion.py `advance`): it speeds up at `up`, brakes at `accel`,
and always stops short of `stop`; a one-cell move from rest to rest takes the closed-form time of that
trapezoid. The layer's robots get going at the rated acceleration and brake at its braking rate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import FleetConfig, FleetService
from fleet.traffic import enable_traffic
from fleet.traffic.motion import advance


def run(stop: float, vmax: float, accel: float, up: float | None, dt: float, steps: int
        ) -> tuple[np.ndarray, np.ndarray]:
    """Progress and rate after each period, from rest at s = 0."""
    s, sd = np.zeros(1), np.zeros(1)
    go, cap, end = np.ones(1, bool), np.full(1, vmax), np.full(1, stop)
    ss, sds = [], []
    for _ in range(steps):
        s, sd = advance(s, sd, end, go, cap, accel, dt, up)
        ss.append(float(s[0]))
        sds.append(float(sd[0]))
    return np.asarray(ss), np.asarray(sds)


def rest_to_rest_s(distance: float, vmax: float, up: float, down: float) -> float:
    """Closed form: time to cover `distance` from rest to rest, speeding up at `up` and braking at `down`."""
    peak = math.sqrt(2.0 * distance / (1.0 / up + 1.0 / down))
    if peak <= vmax:
        return peak / up + peak / down
    cruise = distance - vmax * vmax / (2.0 * up) - vmax * vmax / (2.0 * down)
    return vmax / up + vmax / down + cruise / vmax


def test_speeds_up_at_up_and_brakes_at_accel() -> None:
    dt, up, accel, vmax = 0.1, 1.5, 1.0, 0.8
    s, sd = run(100.0, vmax, accel, up, dt, 20)
    k = np.arange(1, 21)
    np.testing.assert_allclose(sd, np.minimum(k * up * dt, vmax), atol=1e-12)  # far from stop: the ramp, then vmax
    np.testing.assert_allclose(s, np.cumsum(sd) * dt, atol=1e-12)
    # Near a stop 3 cells on: every period's rate still lets it stop in time at `accel` (not at `up`).
    s, sd = run(3.0, vmax, accel, up, dt, 100)
    before = np.concatenate([[0.0], s[:-1]])
    assert np.all(sd * dt + sd * sd / (2.0 * accel) <= 3.0 - before + 1e-12)
    assert s.max() <= 3.0 and s[-1] > 3.0 - 1e-3 and sd[-1] < 1e-2


def test_up_defaults_to_accel() -> None:
    a = run(2.0, 0.8, 1.0, None, 0.1, 40)
    b = run(2.0, 0.8, 1.0, 1.0, 0.1, 40)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


@pytest.mark.parametrize(("vmax", "up"), [(0.8, 1.5), (0.8, 1.0), (2.0, 1.5)])
def test_one_cell_rest_to_rest_matches_the_closed_form(vmax: float, up: float) -> None:
    dt, accel = 1e-3, 1.0
    s, _ = run(1.0, vmax, accel, up, dt, 5000)
    eps = 1e-3  # the profile closes in on its stop for ever: time it to within eps, the last eps braking at accel
    took = (int(np.argmax(s > 1.0 - eps)) + 1) * dt
    assert took == pytest.approx(rest_to_rest_s(1.0, vmax, up, accel) - math.sqrt(2.0 * eps / accel), abs=0.01)


def test_layer_speeds_up_at_the_rated_acceleration_and_brakes_below_it() -> None:
    with FleetService(FleetConfig(world="robot_arena")) as svc:
        tm = enable_traffic(svc, cell=1.0, speed=0.8)
        rated = svc.default_spec().limits.max_linear_accel
        assert rated == pytest.approx(1.5)  # the course robot's rating (configs/robots/diffbot.yaml)
        assert tm.accel_up == pytest.approx(rated)
        assert tm.accel == pytest.approx(min(1.0, 0.7 * rated))
