"""Helper 17p: the Embree caster's fan cache (sim/raycast_fans.py) hands back exactly what casting again gives.

Robots that stand still cast the same rays every scan; their static-scene hits are reused. Checked against the
caster with the cache off on every lidar cast of a world where some robots drive and some stand, and on crafted
fans whose rays differ from a cached fan's by one bit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim import World
from sim import raycast_scene as scene
from sim.raycast_fans import FanCache
from sim.raycast_layout import RayLayout
from sim.sdf_primitives import box
from tests.sim.lidar_fleet import lidar_fleet


@pytest.fixture(scope="module")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    """The shared lidar fleet (tests/sim/lidar_fleet.py)."""
    return lidar_fleet(tmp_path_factory.mktemp("fans"), "fans", world_seed=5, heading_seed=7)


def test_cached_fans_equal_a_fresh_cast(world: World) -> None:
    world.set_raycaster("embree")
    world.cast_rays(np.zeros((1, 3)), np.ones((1, 3)))  # builds the caster
    caster = world.rays.embree
    cast = caster.cast
    casts = 0

    def compare(o: np.ndarray, e: np.ndarray, layout: RayLayout | None = None) -> tuple[np.ndarray, np.ndarray]:
        nonlocal casts
        frac, uid = cast(o, e, layout)
        fans, caster.fans = caster.fans, None  # the same rays, the same moment, no cache
        try:
            ref_frac, ref_uid = cast(o, e, layout)
        finally:
            caster.fans = fans
        assert np.array_equal(frac, ref_frac) and np.array_equal(uid, ref_uid)
        assert (uid >= 0).mean() > 0.3
        casts += 1
        return frac, uid

    caster.cast = compare
    try:
        world.step(6)
    finally:
        del caster.cast
    assert casts == 6
    assert caster.fans is not None and caster.fans.reused >= 6 * 4  # the 6 standing robots, from the 3rd cast


def test_a_fan_whose_rays_differ_by_one_bit_is_cast_again(world: World) -> None:
    caster = world.rays.embree
    g = caster._static_scene()
    assert g is not None
    n = 90
    heading = np.linspace(-np.pi, np.pi, n, endpoint=False)
    layout = RayLayout(np.array([0]), np.array([n]), np.array([0.3]), np.array([0.1]), np.array([0.2]),
                       heading[:1], np.array([heading[1] - heading[0]]), np.array([0.1]), np.array([10.0]))
    o, e = layout.rays()
    d = e - o
    fc = FanCache()
    for _ in range(3):  # stored on the second sighting, reused on the third
        t, uid = fc.cast(g, layout, o, d)
    assert fc.reused == 1 and fc.cast_fans == 2
    ref_t, ref_uid = scene.cast(g, o, d, np.ones(n))
    assert np.array_equal(t, ref_t) and np.array_equal(uid, ref_uid) and np.isfinite(t).sum() > n // 4
    # The same layout parameters, but one ray turned by one ulp: not the cached fan.
    d2 = d.copy()
    k = int(np.flatnonzero(np.isfinite(ref_t))[0])
    d2[k, 0] = np.nextafter(d2[k, 0], np.inf)
    t2, uid2 = fc.cast(g, layout, o, d2)
    assert fc.reused == 1
    ref2 = scene.cast(g, o, d2, np.ones(n))
    assert np.array_equal(t2, ref2[0]) and np.array_equal(uid2, ref2[1])
    # Another scene object (a static layout rebuilt): nothing from the old one.
    g2 = scene.commit([scene.build([(caster._template(int(world.table.body[0]), "fan-test"),
                                     np.eye(4)[None], np.array([99]))])])
    assert g2 is not None
    t3, uid3 = fc.cast(g2, layout, o, d2)
    ref3 = scene.cast(g2, o, d2, np.ones(n))
    assert np.array_equal(t3, ref3[0]) and np.array_equal(uid3, ref3[1])


def test_has_dynamic_models_follows_models_added_and_removed(world: World) -> None:
    """The answer is kept per registry version (asked every cast): adding and removing a movable model flips it."""
    models = world.models
    assert not models.has_dynamic_models()
    crate = box("movable_crate", (0.4, 0.4, 0.4), -4.0, -4.0, 0.2)
    models.add_model(replace(crate, static=False, links=(replace(crate.links[0], mass=1.0,
                                                                 inertia=(0.1, 0, 0, 0.1, 0, 0.1)),)))
    assert models.has_dynamic_models()
    models.remove("movable_crate")
    assert not models.has_dynamic_models()
    models.add_model(box("static_crate", (0.4, 0.4, 0.4), -4.0, -4.0, 0.2))
    assert not models.has_dynamic_models()
    models.remove("static_crate")
