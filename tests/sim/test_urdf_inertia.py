"""Closed-form inertia tensors against hand values and against a numerical volume integral."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.errors import ErrorCode, FleetError
from sim.inertia import Inertia, box_inertia, cylinder_inertia, sphere_inertia


def _grid_inertia(inside, half: tuple[float, float, float], mass: float, n: int = 120) -> np.ndarray:
    """Inertia tensor of a uniform solid by a midpoint grid over its bounding box (independent of the
    closed forms): I = ρ ∫ (|r|² E − r rᵀ) dV."""
    axes = [(np.arange(n) + 0.5) / n * 2 * h - h for h in half]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    keep = inside(x, y, z)
    p = np.stack([x[keep], y[keep], z[keep]], axis=1)
    dm = mass / len(p)
    r2 = (p * p).sum(axis=1)
    return dm * (np.eye(3) * r2.sum() - p.T @ p)


def test_box_inertia_matches_hand_values_for_the_chassis():
    i = box_inertia(3.25, (0.5, 0.4, 0.2))
    assert i.ixx == pytest.approx(3.25 * (0.4**2 + 0.2**2) / 12)  # 0.0541667
    assert i.iyy == pytest.approx(3.25 * (0.5**2 + 0.2**2) / 12)  # 0.0785417
    assert i.izz == pytest.approx(3.25 * (0.5**2 + 0.4**2) / 12)  # 0.1110417
    assert (i.ixy, i.ixz, i.iyz) == (0.0, 0.0, 0.0)


def test_box_inertia_matches_a_volume_integral():
    size = (0.5, 0.4, 0.2)
    half = tuple(s / 2 for s in size)
    numeric = _grid_inertia(lambda x, y, z: np.ones_like(x, dtype=bool), half, 3.25)  # type: ignore[arg-type]
    np.testing.assert_allclose(box_inertia(3.25, size).matrix(), numeric, rtol=1e-3, atol=1e-9)


def test_cylinder_inertia_matches_hand_values_for_the_wheel_and_mast():
    wheel = cylinder_inertia(0.5, 0.1, 0.05, axis="y")
    assert wheel.iyy == pytest.approx(0.5 * 0.1**2 / 2)  # 0.0025 about the axle
    assert wheel.ixx == wheel.izz == pytest.approx(0.5 * (3 * 0.1**2 + 0.05**2) / 12)
    mast = cylinder_inertia(0.5, 0.025, 0.3)
    assert mast.izz == pytest.approx(0.5 * 0.025**2 / 2)
    assert mast.ixx == mast.iyy == pytest.approx(0.5 * (3 * 0.025**2 + 0.3**2) / 12)


def test_cylinder_inertia_matches_a_volume_integral():
    r, h, m = 0.1, 0.05, 0.5
    numeric = _grid_inertia(lambda x, y, z: x * x + z * z <= r * r, (r, h / 2, r), m, n=200)
    np.testing.assert_allclose(cylinder_inertia(m, r, h, axis="y").matrix(), numeric, rtol=5e-3, atol=1e-8)


def test_sphere_inertia_is_two_fifths_m_r_squared():
    i = sphere_inertia(0.25, 0.05)
    assert i.ixx == i.iyy == i.izz == pytest.approx(0.4 * 0.25 * 0.05**2)


def test_is_physical_rejects_impossible_tensors():
    assert not Inertia(1.0, 0.0, 0.0, 1.0, 0.0, 3.0).is_physical()  # 1 + 1 < 3: triangle inequality
    assert not Inertia(-1.0, 0.0, 0.0, 1.0, 0.0, 1.0).is_physical()
    assert not Inertia(1.0, 2.0, 0.0, 1.0, 0.0, 1.0).is_physical()  # eigenvalue -1: not positive definite
    assert Inertia(1.0, 0.0, 0.0, 1.0, 0.0, 2.0).is_physical()  # a flat plate sits on the boundary


def test_bad_dimensions_are_input_errors():
    with pytest.raises(FleetError) as err:
        box_inertia(1.0, (0.5, 0.0, 0.2))
    assert err.value.code == ErrorCode.INVALID_ARGUMENT
    with pytest.raises(FleetError):
        cylinder_inertia(-1.0, 0.1, 0.1)
    with pytest.raises(FleetError):
        sphere_inertia(1.0, math.nan)


dims = st.floats(1e-3, 10.0)


@settings(max_examples=60, deadline=None)
@given(m=dims, x=dims, y=dims, z=dims)
def test_every_box_and_cylinder_is_physical(m, x, y, z):
    assert box_inertia(m, (x, y, z)).is_physical()
    for axis in ("x", "y", "z"):
        assert cylinder_inertia(m, x, y, axis=axis).is_physical()
