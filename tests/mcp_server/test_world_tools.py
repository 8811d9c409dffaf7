"""World and model tools: list/spawn/delete models, model state, forces, physics, gravity."""

from __future__ import annotations

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, ok

pytestmark = pytest.mark.anyio

BOX = """<sdf version="1.9"><model name="crate"><link name="l"><inertial><mass>2.0</mass></inertial>
<collision name="c"><geometry><box><size>0.4 0.4 0.4</size></box></geometry></collision>
<visual name="v"><geometry><box><size>0.4 0.4 0.4</size></box></geometry></visual></link></model></sdf>"""

# sim/world_models.physics_properties reads params["gravity"], but pybullet 3.2.7's getPhysicsEngineParameters
# returns gravityAccelerationX/Y/Z: every physics read fails until sim fixes it (reported to the lead).


@pytest.fixture(scope="module")
def world_name() -> str:
    return "robot_arena"


async def test_list_models_in_three_formats(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5, -5, 0))
    s = await ok(client, "list_models")
    assert s["count"] == len(service.world.list_models()) and s["by_kind"]["robot"] == 1 and "box_crate" in s["names"]
    n = await ok(client, "list_models", {"response_format": "normal", "kind": "robot"})
    assert n["models"] == [{"name": "r1", "kind": "robot", "x": -5.0, "y": -5.0}]
    f = await ok(client, "list_models", {"response_format": "full", "kind": "sdf"})
    crate = next(m for m in f["models"] if m["name"] == "box_crate")
    assert crate["pose"]["z"] > 0 and len(crate["linear_velocity"]) == 3
    await err(client, "list_models", {"kind": "spaceship"}, "INVALID_ARGUMENT")


async def test_spawn_from_xml_appears_in_the_world_and_its_map(client, service: FleetService) -> None:
    s = await ok(client, "spawn_model", {"xml": BOX, "pose": {"x": 0.5, "y": 0.0, "z": 0.2}, "static": True})
    assert s["models"] == ["crate"] and "crate" in service.world.models.names()
    grid = service.static_grid()
    r, c = grid.world_to_cell(0.5, 0.0)
    assert grid.occupied()[r, c], "a spawned static box must show up in the rasterised map"
    st = await ok(client, "get_model_state", {"name": "crate"})
    assert st["pose"]["x"] == pytest.approx(0.5) and st["static"] is True
    await err(client, "spawn_model", {"xml": BOX}, "INVALID_ARGUMENT")  # the name is taken now
    await err(client, "spawn_model", {}, "INVALID_ARGUMENT")
    await err(client, "spawn_model", {"file": "/etc/passwd"}, "NOT_FOUND")  # outside = missing: no existence oracle
    await err(client, "spawn_model", {"xml": "<sdf version='1.9'><world/>"})


async def test_delete_model_and_robots_are_protected(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5, -5, 0))
    await ok(client, "delete_model", {"name": "box_crate"})
    assert "box_crate" not in service.world.models.names()
    await err(client, "delete_model", {"name": "r1"}, "INVALID_ARGUMENT")
    await err(client, "delete_model", {"name": "box_crate"})


async def test_set_model_state_teleports_and_apply_force_moves_a_dynamic_body(client, service: FleetService) -> None:
    await ok(client, "spawn_model", {"xml": BOX, "pose": {"x": 2.0, "y": 2.0, "z": 0.2}, "static": False})
    st = await ok(client, "set_model_state", {"name": "crate", "pose": {"x": 3.0, "y": 2.0, "z": 0.2}})
    assert st["pose"]["x"] == pytest.approx(3.0, abs=1e-6)
    service.step(50)
    await ok(client, "apply_force", {"name": "crate", "force": [400.0, 0.0, 0.0]})
    service.step(1)
    assert service.get_model_state("crate").linear_velocity[0] > 0.5
    await err(client, "set_model_state", {"name": "ghost", "pose": {"x": 0}})
    await err(client, "apply_force", {"name": "crate", "force": [1.0, 2.0]}, "INVALID_ARGUMENT")


async def test_world_properties_report_bounds_and_spawn_points(client, service: FleetService) -> None:
    w = await ok(client, "get_world_properties")
    assert w["bounds"] == pytest.approx(list(service.world.description.bounds()), abs=1e-3)
    assert [s["name"] for s in w["spawn_points"]] == ["spawn_start"]


async def test_gravity_presets_and_physics_properties(client, service: FleetService) -> None:
    g = await ok(client, "set_gravity", {"preset": "moon"})
    assert g["gravity"] == pytest.approx([0, 0, -1.62])
    p = await ok(client, "set_physics_properties", {"solver_iterations": 77})
    assert p["solver_iterations"] == 77
    assert (await ok(client, "get_physics_properties"))["gravity"] == pytest.approx([0, 0, -1.62])


async def test_physics_bad_input(client) -> None:
    await err(client, "set_gravity", {"preset": "custom"}, "INVALID_ARGUMENT")
    await err(client, "set_gravity", {"preset": "jupiter"}, "INVALID_ARGUMENT")
    await err(client, "set_physics_properties", {"solver_iterations": 0}, "INVALID_ARGUMENT")
    await err(client, "set_physics_properties", {"gravity": [0, 0]}, "INVALID_ARGUMENT")
