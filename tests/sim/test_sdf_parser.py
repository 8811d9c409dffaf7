"""parse_sdf on hand-written Gazebo SDF: composed poses, includes, meshes, lights, errors with file:line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sim.errors import ErrorCode, FleetError
from sim.sdf_geometry import GAZEBO_COLOURS
from sim.sdf_parser import parse_sdf, parse_sdf_string
from sim.types import Box, Cylinder, Mesh, Pose2D, Pose3D, SpawnPoint

CUBE_OBJ = "\n".join(
    [f"v {x} {y} {z}" for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    + ["f 1 3 2", "f 2 3 4", "f 5 6 7", "f 6 8 7", "f 1 2 5", "f 2 6 5",
       "f 3 7 4", "f 4 7 8", "f 1 5 3", "f 3 5 7", "f 2 4 6", "f 4 8 6"]) + "\n"

CRATE_CONFIG = """<?xml version="1.0"?>
<model><name>crate</name><sdf version="1.5">model-1_5.sdf</sdf><sdf version="1.6">model.sdf</sdf></model>
"""

CRATE_SDF = """<?xml version="1.0"?>
<sdf version="1.6">
  <model name="crate">
    <link name="body">
      <pose>0 0 0.25 0 0 0</pose>
      <inertial><mass>2.5</mass><inertia><ixx>0.1</ixx><iyy>0.2</iyy><izz>0.3</izz></inertia></inertial>
      <collision name="box"><geometry><box><size>0.5 0.5 0.5</size></box></geometry>
        <surface><friction><ode><mu>0.6</mu><mu2>0.6</mu2></ode></friction></surface></collision>
      <visual name="box"><geometry><box><size>0.5 0.5 0.5</size></box></geometry>
        <material><script><uri>file://media/materials/scripts/gazebo.material</uri>
        <name>Gazebo/Wood</name></script></material></visual>
      <visual name="logo"><pose>0.26 0 0 0 0 0</pose>
        <geometry><mesh><uri>model://crate/meshes/cube.obj</uri><scale>0.02 0.3 0.3</scale></mesh></geometry>
      </visual>
    </link>
  </model>
</sdf>
"""

WORLD_16 = """<?xml version="1.0" ?>
<sdf version="1.6">
  <world name="gazebo_classic">
    <physics name="fast" type="ode" default="true">
      <max_step_size>0.004</max_step_size>
      <real_time_factor>2</real_time_factor>
      <ode><solver><iters>50</iters></solver></ode>
    </physics>
    <gravity>0 0 -9.7</gravity>
    <scene><ambient>0.4 0.4 0.4 1</ambient></scene>
    <include><uri>model://sun</uri></include>
    <light type="point" name="bulb">
      <pose>1 2 3 0 0 0</pose>
      <diffuse>0.5 0.6 0.7 1</diffuse>
      <attenuation><range>20</range></attenuation>
    </light>
    <light type="spot" name="spot"><pose>0 0 4 0 0 0</pose><direction>0 0 -1</direction></light>
    <include><uri>model://ground_plane</uri></include>
    <model name="station">
      <static>true</static>
      <pose>2 1 0 0 0 0.3</pose>
      <link name="base">
        <pose>1 0 0.5 0 0 0</pose>
        <collision name="c"><geometry><box><size>1 2 1</size></box></geometry></collision>
        <visual name="v"><geometry><box><size>1 2 1</size></box></geometry>
          <material><ambient>0.1 0.2 0.3 1</ambient><diffuse>0.4 0.5 0.6 1</diffuse></material></visual>
        <sensor name="cam" type="camera"/>
      </link>
      <model name="arm">
        <pose>0 1 0 0 0 0.5</pose>
        <link name="post">
          <pose>0.5 0 0 0 0 0</pose>
          <collision name="c"><pose>0 0 0.6 0 0 0</pose>
            <geometry><cylinder><radius>0.1</radius><length>1.2</length></cylinder></geometry></collision>
        </link>
      </model>
      <plugin name="mover" filename="libmover.so"/>
    </model>
    <model name="sculpture">
      <static>1</static>
      <pose>-3 -1 0.5 0 0 0</pose>
      <link name="l">
        <collision name="mesh"><geometry><mesh><uri>meshes/cube.obj</uri><scale>2 2 1</scale></mesh></geometry>
        </collision>
        <collision name="fancy"><geometry><mesh><uri>meshes/fancy.dae</uri></mesh></geometry></collision>
      </link>
    </model>
    <include>
      <uri>model://crate</uri>
      <name>crate_1</name>
      <pose>4 -2 0 0 0 1.0</pose>
    </include>
    <include><uri>model://crate</uri><name>crate_fixed</name><pose>-4 3 0 0 0 0</pose><static>true</static></include>
    <model name="spawn_robot">
      <static>true</static>
      <pose>-2 -2 0 0 0 0.75</pose>
      <link name="pad"><visual name="v"><geometry><box><size>0.5 0.5 0.01</size></box></geometry></visual></link>
    </model>
    <actor name="walker"><skin><filename>walk.dae</filename></skin></actor>
  </world>
</sdf>
"""


def write_world_16(tmp: Path) -> tuple[Path, Path]:
    """The 1.6 world, its mesh and its crate model under `tmp`; returns (world file, models dir)."""
    models = tmp / "models"
    (models / "crate" / "meshes").mkdir(parents=True)
    (models / "crate" / "model.config").write_text(CRATE_CONFIG)
    (models / "crate" / "model.sdf").write_text(CRATE_SDF)
    (models / "crate" / "meshes" / "cube.obj").write_text(CUBE_OBJ)
    (tmp / "meshes").mkdir()
    (tmp / "meshes" / "cube.obj").write_text(CUBE_OBJ)
    world = tmp / "classic.world"
    world.write_text(WORLD_16)
    return world, models


def _expect_pose(actual: Pose3D, x: float, y: float, z: float, yaw: float) -> None:
    assert (actual.x, actual.y, actual.z) == pytest.approx((x, y, z), abs=1e-12)
    assert math.remainder(actual.yaw - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_gazebo_16_world_loads_with_composed_world_poses(tmp_path: Path) -> None:
    path, models = write_world_16(tmp_path)
    w = parse_sdf(path, model_path=[str(models)])
    assert [m.name for m in w.models] == ["ground_plane", "station", "sculpture", "crate_1", "crate_fixed"]
    assert [m.name for m in w.obstacle_models()] == ["station", "sculpture", "crate_1", "crate_fixed"]
    cols = {(m.name, link.name, c.name): wp for m in w.models for link, c, wp in m.world_collisions()}
    # station (2, 1, yaw 0.3) ⊕ base (1, 0, 0.5)
    _expect_pose(cols[("station", "base", "c")], 2 + math.cos(0.3), 1 + math.sin(0.3), 0.5, 0.3)
    # station ⊕ arm (0, 1, yaw 0.5) ⊕ post (0.5, 0, 0) ⊕ collision (0, 0, 0.6)
    ax, ay = 2 - math.sin(0.3), 1 + math.cos(0.3)
    _expect_pose(cols[("station", "arm::post", "c")], ax + 0.5 * math.cos(0.8), ay + 0.5 * math.sin(0.8), 0.6, 0.8)
    _expect_pose(cols[("crate_1", "body", "box")], 4, -2, 0.25, 1.0)


def test_includes_apply_name_pose_static_and_keep_mass_friction_material(tmp_path: Path) -> None:
    path, models = write_world_16(tmp_path)
    w = parse_sdf(path, model_path=[str(models)])
    crate, fixed = (next(m for m in w.models if m.name == n) for n in ("crate_1", "crate_fixed"))
    assert (crate.static, fixed.static) == (False, True)
    assert crate.source == "model://crate"
    body = crate.links[0]
    assert body.mass == 2.5 and body.inertia == (0.1, 0.0, 0.0, 0.2, 0.0, 0.3)
    assert body.collisions[0].friction == 0.6
    box_vis, logo = body.visuals
    assert box_vis.material == "Gazebo/Wood" and box_vis.rgba == GAZEBO_COLOURS["Gazebo/Wood"]
    assert isinstance(logo.geometry, Mesh)
    assert Path(logo.geometry.path) == (models / "crate" / "meshes" / "cube.obj").resolve()
    station = next(m for m in w.models if m.name == "station")
    assert station.links[0].visuals[0].rgba == (0.4, 0.5, 0.6, 1.0)  # diffuse wins over ambient


def test_mesh_lights_physics_spawn_and_unsupported(tmp_path: Path) -> None:
    path, models = write_world_16(tmp_path)
    w = parse_sdf(path, model_path=[str(models)])
    sculpture = next(m for m in w.models if m.name == "sculpture")
    (mesh,) = sculpture.links[0].collisions  # the .dae collision is dropped, and listed below
    assert isinstance(mesh.geometry, Mesh) and mesh.geometry.scale == (2.0, 2.0, 1.0)
    assert Path(mesh.geometry.path) == (tmp_path / "meshes" / "cube.obj").resolve()
    assert [(lt.name, lt.type) for lt in w.lights] == [("sun", "directional"), ("bulb", "point"), ("spot", "spot")]
    assert w.lights[1].diffuse == (0.5, 0.6, 0.7, 1.0) and w.lights[1].pose.z == 3.0
    assert w.physics.step_size == 0.004 and w.physics.real_time_factor == 2.0
    assert w.physics.gravity == (0.0, 0.0, -9.7)
    assert w.spawn_points == (SpawnPoint("spawn_robot", Pose2D(-2.0, -2.0, 0.75)),)
    assert w.ground_material == "Gazebo/Grey"
    un = set(w.unsupported)
    assert {"world/actor", "world/physics/ode", "world/model[station]/plugin",
            "world/model[station]/link[base]/sensor"} <= un
    assert any(u.startswith("world/model[sculpture]/link[l]/collision[fancy]/geometry/mesh") and ".dae" in u
               for u in un)
    assert len(w.unsupported) == len(un)  # each once


def test_relative_to_frames_sdf_18() -> None:
    text = """<sdf version="1.8"><world name="w">
      <model name="a"><static>true</static><pose>1 0 0 0 0 1.5707963267948966</pose>
        <frame name="mount" attached_to="base"><pose relative_to="base">0 0 1 0 0 0</pose></frame>
        <link name="base"><pose>2 0 0 0 0 0</pose></link>
        <link name="top"><pose relative_to="mount">1 0 0 0 0 0</pose>
          <collision name="c"><pose relative_to="__model__">0 3 0 0 0 0</pose>
            <geometry><sphere><radius>0.5</radius></sphere></geometry></collision></link>
      </model>
      <model name="b"><static>true</static><pose relative_to="a">0 0 0 0 0 0</pose>
        <link name="l"><collision name="c"><geometry><box><size>1 1 1</size></box></geometry></collision></link>
      </model>
      <frame name="spawn_left"><pose relative_to="a">0 1 0 0 0 0</pose></frame>
    </world></sdf>"""
    w = parse_sdf_string(text)
    a, b = w.models
    top = a.links[1]
    # base at (2,0,0) in a; mount 1 m above base; top 1 m along x of mount: (3, 0, 1) in a
    assert top.pose.position == pytest.approx((3.0, 0.0, 1.0))
    (_, _col, wp), = [x for x in a.world_collisions() if x[0].name == "top"]
    # collision at (0, 3, 0) in the model frame → world: a ⊕ (0,3,0) = (1 - 3, 0, 0)
    assert wp.position == pytest.approx((-2.0, 0.0, 0.0), abs=1e-12)
    assert b.pose.position == pytest.approx((1.0, 0.0, 0.0)) and b.pose.yaw == pytest.approx(math.pi / 2)
    (sp,) = w.spawn_points
    assert (sp.name, sp.pose.x, sp.pose.y) == ("spawn_left", pytest.approx(0.0, abs=1e-12), pytest.approx(0.0))


def test_bare_model_string_gives_a_one_model_description() -> None:
    w = parse_sdf_string('<model name="ball"><pose degrees="true">0 0 1 0 0 90</pose><link name="l">'
                         '<collision name="c"><geometry><sphere><radius>0.2</radius></sphere></geometry>'
                         '</collision></link></model>')
    (m,) = w.models
    assert (w.name, m.name, m.static) == ("ball", "ball", False)
    assert m.pose.yaw == pytest.approx(math.pi / 2) and m.links[0].mass == 1.0  # SDF default mass


def test_malformed_xml_names_file_and_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.world"
    bad.write_text('<sdf version="1.6">\n<world name="w">\n<model name="m">\n<link name="l">\n</model>\n'
                   "</world>\n</sdf>\n")
    with pytest.raises(FleetError) as e:
        parse_sdf(bad)
    assert e.value.code == ErrorCode.INVALID_CONFIG
    assert f"{bad}:5:" in e.value.message and "mismatched tag" in e.value.message


def test_wrong_value_type_names_element_and_line(tmp_path: Path) -> None:
    bad = tmp_path / "typo.world"
    bad.write_text('<sdf version="1.6"><world name="w">\n<model name="m"><link name="l">\n'
                   '<collision name="c"><geometry><cylinder>\n<radius>wide</radius><length>1</length>\n'
                   "</cylinder></geometry></collision></link></model></world></sdf>\n")
    with pytest.raises(FleetError) as e:
        parse_sdf(bad)
    assert e.value.code == ErrorCode.INVALID_CONFIG
    assert f"{bad}:4:" in e.value.message and "<radius>" in e.value.message and "wide" in e.value.message


def test_missing_include_names_uri_and_search_path(tmp_path: Path) -> None:
    text = '<sdf version="1.6"><world name="w"><include><uri>model://no_such_thing</uri></include></world></sdf>'
    with pytest.raises(FleetError) as e:
        parse_sdf_string(text, model_path=[str(tmp_path)])
    assert e.value.code == ErrorCode.NOT_FOUND
    assert "model://no_such_thing" in e.value.message and str(tmp_path) in e.value.hint


def test_unknown_relative_to_and_bad_sizes_are_errors() -> None:
    with pytest.raises(FleetError, match="relative_to 'nowhere'"):
        parse_sdf_string('<model name="m"><link name="l"><pose relative_to="nowhere">0 0 0 0 0 0</pose></link>'
                         "</model>")
    with pytest.raises(FleetError, match="positive"):
        parse_sdf_string('<model name="m"><static>1</static><link name="l"><collision name="c"><geometry>'
                         "<box><size>1 -1 1</size></box></geometry></collision></link></model>")


def test_geometry_kinds_parse_to_their_types() -> None:
    w = parse_sdf_string('<model name="m"><static>1</static><link name="l">'
                         '<collision name="a"><geometry><box><size>1 2 3</size></box></geometry></collision>'
                         '<collision name="b"><geometry><cylinder><radius>0.5</radius><length>2</length>'
                         "</cylinder></geometry></collision>"
                         '<collision name="c"><geometry><capsule><radius>0.1</radius><length>1</length>'
                         "</capsule></geometry></collision></link></model>")
    a, b = w.models[0].links[0].collisions
    assert a.geometry == Box((1.0, 2.0, 3.0)) and b.geometry == Cylinder(0.5, 2.0)
    assert "sdf/model[m]/link[l]/collision[c]/geometry/capsule" in w.unsupported
