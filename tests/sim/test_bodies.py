"""Bodies built in a real PyBullet DIRECT client are where (and what) the description says."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from sim.bodies import BuiltModel, build_model, build_models, remove_model
from sim.errors import FleetError
from sim.sdf_context import compose
from sim.sdf_parser import parse_sdf
from sim.sdf_primitives import box, ground_plane, marker
from sim.types import Collision, Link, Mesh, ModelDescription, Plane, WorldDescription
from sim.worldgen import warehouse
from tests.sim.test_sdf_parser import write_world_16


@pytest.fixture
def client() -> Iterator[int]:
    c = p.connect(p.DIRECT)
    yield c
    p.disconnect(c)


@pytest.fixture
def classic(tmp_path: Path, client: int) -> tuple[WorldDescription, dict[str, BuiltModel]]:
    path, models = write_world_16(tmp_path)
    w = parse_sdf(path, model_path=[str(models)])
    return w, {m.name: build_model(client, m, ground_texture=w.ground_material) for m in w.models}


def _aabb(client: int, uid: int) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = p.getAABB(uid, physicsClientId=client)
    return np.array(lo), np.array(hi)


def test_bodies_sit_at_composed_link_poses(classic: tuple[WorldDescription, dict[str, BuiltModel]],
                                           client: int) -> None:
    w, built = classic
    for m in w.models:
        for link, uid in zip(m.links, built[m.name].body_uids, strict=False):
            if all(isinstance(c.geometry, Plane) for c in link.collisions) and link.collisions:
                continue
            pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
            expect = compose(m.pose, link.pose)
            assert pos == pytest.approx(expect.position, abs=1e-9), (m.name, link.name)
            assert abs(float(np.dot(orn, expect.quaternion))) == pytest.approx(1.0, abs=1e-9)
            assert built[m.name].link_names[uid] == {-1: link.name}


def test_box_and_nested_cylinder_extents_match_closed_form(
        classic: tuple[WorldDescription, dict[str, BuiltModel]], client: int) -> None:
    _, built = classic
    base, post = built["station"].body_uids
    # 1 × 2 × 1 box yawed 0.3 rad, centred at station ⊕ (1, 0, 0.5)
    c, s = math.cos(0.3), math.sin(0.3)
    centre = np.array([2 + c, 1 + s, 0.5])
    half = np.array([0.5 * c + 1.0 * s, 0.5 * s + 1.0 * c, 0.5])
    lo, hi = _aabb(client, base)
    assert lo == pytest.approx(centre - half, abs=1e-3) and hi == pytest.approx(centre + half, abs=1e-3)
    # cylinder r = 0.1, length 1.2 standing at station ⊕ arm ⊕ post
    px = 2 - s + 0.5 * math.cos(0.8)
    py = 1 + c + 0.5 * math.sin(0.8)
    # (PyBullet's AABB of a yawed cylinder is loose, so probe the surface with rays instead)
    side = p.rayTest([px + 1.0, py, 0.6], [px - 1.0, py, 0.6], physicsClientId=client)[0]
    top = p.rayTest([px, py, 2.0], [px, py, 0.0], physicsClientId=client)[0]
    assert side[0] == top[0] == post
    assert side[3][0] == pytest.approx(px + 0.1, abs=1e-4) and top[3][2] == pytest.approx(1.2, abs=1e-4)


def test_mesh_is_scaled_and_placed(classic: tuple[WorldDescription, dict[str, BuiltModel]], client: int) -> None:
    _, built = classic
    (uid,) = built["sculpture"].body_uids  # unit cube scaled (2, 2, 1) at (-3, -1, 0.5)
    lo, hi = _aabb(client, uid)
    assert lo == pytest.approx([-4.0, -2.0, 0.0], abs=0.02) and hi == pytest.approx([-2.0, 0.0, 1.0], abs=0.02)


def test_dynamic_model_gets_mass_inertia_friction_static_gets_none(
        classic: tuple[WorldDescription, dict[str, BuiltModel]], client: int) -> None:
    _, built = classic
    info = p.getDynamicsInfo(built["crate_1"].body_uids[0], -1, physicsClientId=client)
    assert info[0] == pytest.approx(2.5) and info[1] == pytest.approx(0.6)
    assert info[2] == pytest.approx((0.1, 0.2, 0.3))
    assert p.getDynamicsInfo(built["crate_fixed"].body_uids[0], -1, physicsClientId=client)[0] == 0.0


def test_ground_collides_and_markers_do_not(client: int) -> None:
    built = build_models(client, [ground_plane(), marker("goal_marker", 1.0, 2.0)])
    ground_uid, marker_uid = built[0].body_uids[0], built[1].body_uids[0]
    (hit,) = p.rayTest([1.0, 2.0, 0.5], [1.0, 2.0, -1.0], physicsClientId=client)  # straight down the pole
    assert hit[0] == ground_uid and hit[3][2] == pytest.approx(0.0, abs=1e-6)
    (across,) = p.rayTest([0.0, 2.0, 0.5], [2.0, 2.0, 0.5], physicsClientId=client)  # through the pole
    assert across[0] == -1 and marker_uid not in (hit[0], across[0])


def _floor_image(client: int) -> np.ndarray:
    view = p.computeViewMatrix([0, 0, 3], [0, 0, 0], [0, 1, 0])
    proj = p.computeProjectionMatrixFOV(60, 1, 0.1, 10)
    rgb = p.getCameraImage(64, 64, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=client)[2]
    return np.asarray(rgb, np.float64).reshape(64, 64, 4)[:, :, :3]


def test_ground_with_a_material_is_textured_and_plain_ground_is_not(client: int) -> None:
    ground = ground_plane()
    plain_links = tuple(replace(lk, visuals=tuple(replace(v, material=None) for v in lk.visuals))
                        for lk in ground.links)
    build_model(client, replace(ground, links=plain_links))
    assert _floor_image(client).std() < 1.0  # a flat colour
    other = p.connect(p.DIRECT)
    try:
        build_model(other, ground_plane(material="Gazebo/Grey"))
        assert _floor_image(other).std() > 10.0  # tiles and grout
    finally:
        p.disconnect(other)


def test_batched_warehouse_shelves_are_where_the_description_says(client: int) -> None:
    w = warehouse(size=24.0)
    built = build_models(client, w.models, ground_texture=w.ground_material)
    uids = [u for b in built for u in b.body_uids]
    assert len(set(uids)) == len(uids) == p.getNumBodies(physicsClientId=client)
    shelves = [(m, b) for m, b in zip(w.models, built, strict=True) if m.name.startswith("shelf_")]
    assert len(shelves) > 10
    for m, b in shelves:
        (uid,) = b.body_uids
        lo, hi = _aabb(client, uid)
        assert lo == pytest.approx([m.pose.x - 1.2, m.pose.y - 0.45, 0.0], abs=1e-3)
        assert hi == pytest.approx([m.pose.x + 1.2, m.pose.y + 0.45, 2.2], abs=1e-3)
        p.getBodyInfo(uid, physicsClientId=client)  # raises if the client's body cache missed batched bodies


def test_remove_model_removes_its_bodies(client: int) -> None:
    crate = box("crate", (1.0, 1.0, 1.0), 3.0, 0.0)
    built = build_model(client, crate)
    assert p.rayTest([0, 0, 0.5], [6, 0, 0.5], physicsClientId=client)[0][0] == built.body_uids[0]
    remove_model(client, built)
    assert p.getNumBodies(physicsClientId=client) == 0
    assert p.rayTest([0, 0, 0.5], [6, 0, 0.5], physicsClientId=client)[0][0] == -1


def test_dynamic_link_without_mass_is_rejected(client: int) -> None:
    crate = box("crate", (1.0, 1.0, 1.0), 0.0, 0.0)
    with pytest.raises(FleetError, match="mass"):
        build_model(client, ModelDescription("crate", crate.pose, False, crate.links))


def test_a_failing_model_leaves_no_bodies_behind(client: int, tmp_path: Path) -> None:
    good = box("crate", (1.0, 1.0, 1.0), 0.0, 0.0)
    gone = Mesh("meshes/gone.obj", str(tmp_path / "gone.obj"))
    bad = ModelDescription("statue", links=(Link("l", collisions=(Collision("c", gone),)),))
    with pytest.raises(FleetError, match=r"gone\.obj"):
        build_models(client, [ground_plane(), good, bad])
    assert p.getNumBodies(physicsClientId=client) == 0
