"""Reading URDF: forward kinematics against closed forms, and bad files rejected with file:line errors."""

import math

import numpy as np
import pytest

from sim.errors import ErrorCode, FleetError
from sim.types import Box, Mesh
from sim.urdf_parser import parse_urdf

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"><inertial><mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
  </inertial></link>
  <link name="upper"><inertial><mass value="1.5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
  </inertial>
    <collision><origin xyz="0 0 0" rpy="0.785398163397 0 0"/><geometry><box size="1 0.2 0.4"/></geometry></collision>
  </link>
  <link name="slider"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <origin xyz="0 0 1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="2"/>
  </joint>
  <joint name="rail" type="prismatic">
    <parent link="upper"/><child link="slider"/>
    <origin xyz="1 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
  </joint>
  <gazebo reference="upper"><mu1>0.7</mu1></gazebo>
</robot>
"""


def _error(text: str) -> FleetError:
    with pytest.raises(FleetError) as err:
        parse_urdf(text)
    assert err.value.code == ErrorCode.INVALID_CONFIG
    return err.value


def test_forward_kinematics_matches_the_closed_form():
    robot = parse_urdf(ARM)
    assert robot.root == "base"
    q = math.pi / 2
    poses = robot.link_poses({"shoulder": q, "rail": 0.3})
    # Shoulder turns the upper link about z at height 1; the rail then slides 1 + 0.3 m along upper's x.
    assert poses["upper"].position == pytest.approx((0.0, 0.0, 1.0))
    assert poses["upper"].yaw == pytest.approx(q)
    assert poses["slider"].position == pytest.approx((1.3 * math.cos(q), 1.3 * math.sin(q), 1.0), abs=1e-12)
    limit = robot.joints["shoulder"].limit
    assert limit is not None and (limit.lower, limit.upper, limit.effort, limit.velocity) == (-1, 1, 5, 2)


def test_unknown_joint_or_link_names_in_queries_are_errors():
    robot = parse_urdf(ARM)
    with pytest.raises(FleetError) as err:
        robot.link_poses({"elbow": 1.0})
    assert err.value.code == ErrorCode.INVALID_ARGUMENT and "elbow" in err.value.message
    with pytest.raises(FleetError) as err:
        robot.lowest_point("forearm")
    assert err.value.code == ErrorCode.NOT_FOUND


def test_total_mass_counts_links_without_inertial_as_massless():
    robot = parse_urdf(ARM)
    assert robot.links["slider"].inertial is None
    assert robot.total_mass() == pytest.approx(3.5)


def test_lowest_point_of_a_tilted_box_is_the_closed_form():
    robot = parse_urdf(ARM)
    assert robot.links["upper"].collisions[0].geometry == Box((1.0, 0.2, 0.4))
    half_height = 0.5 * (0.2 * math.sin(math.pi / 4) + 0.4 * math.cos(math.pi / 4))  # rolled 45° about x
    assert robot.lowest_point("upper") == pytest.approx(1.0 - half_height, abs=1e-9)


def test_gazebo_link_properties_are_attached_to_the_link():
    assert parse_urdf(ARM).links["upper"].gazebo == {"mu1": "0.7"}


def test_reads_a_file_and_resolves_mesh_paths_next_to_it(tmp_path):
    text = ARM.replace('<link name="slider"/>', '<link name="slider"><visual><geometry>'
                       '<mesh filename="meshes/s.stl" scale="2 2 2"/></geometry></visual></link>')
    path = tmp_path / "arm.urdf"
    path.write_text(text)
    robot = parse_urdf(path)
    mesh = robot.links["slider"].visuals[0].geometry
    assert isinstance(mesh, Mesh)
    assert (mesh.path, mesh.scale) == (str(tmp_path / "meshes" / "s.stl"), (2.0, 2.0, 2.0))
    assert robot.source == str(path)


def test_malformed_xml_names_the_file_and_line(tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="r">\n  <link name="a">\n</robot>\n')
    with pytest.raises(FleetError) as err:
        parse_urdf(path)
    assert err.value.code == ErrorCode.INVALID_CONFIG
    assert err.value.message.startswith(f"{path}:4: malformed XML: mismatched tag")


def test_a_joint_naming_a_missing_link_is_an_error_naming_both():
    err = _error(ARM.replace('<child link="slider"/>', '<child link="slidr"/>'))
    assert "joint 'rail' names child link 'slidr'" in err.message
    assert err.message.startswith("<string>:16:")  # the <parent>/<child> line
    assert "slider" in err.hint  # lists the links that exist


def test_duplicate_link_names_are_an_error_at_the_second():
    err = _error(ARM.replace('<link name="slider"/>', '<link name="upper"/>'))
    assert err.message == "<string>:9: duplicate link name 'upper'"


def test_negative_mass_is_an_error_naming_the_link():
    err = _error(ARM.replace('<mass value="1.5"/>', '<mass value="-1.5"/>'))
    assert err.message == "<string>:5: link 'upper' has a negative mass (-1.5 kg)"


def test_non_numeric_values_name_the_element_and_line():
    err = _error(ARM.replace('xyz="1 0 0" rpy', 'xyz="1 zero 0" rpy'))
    assert err.message.startswith('<string>:17: <origin xyz="1 zero 0">: expected 3 finite number(s)')


def test_a_forest_or_loop_is_not_a_tree():
    err = _error(ARM.replace('<parent link="upper"/><child link="slider"/>',
                             '<parent link="slider"/><child link="upper"/>'))
    assert "child of two joints" in err.message
    err = _error(ARM.replace("""  <joint name="rail" type="prismatic">
    <parent link="upper"/><child link="slider"/>
    <origin xyz="1 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
  </joint>
""", ""))
    assert "expected one root link, found base, slider" in err.message


def test_unknown_joint_type_and_gazebo_reference_are_errors():
    assert "valid types" in _error(ARM.replace('type="prismatic"', 'type="slide"')).hint
    assert "names no link or joint" in _error(ARM.replace('reference="upper"', 'reference="uper"')).message


def test_xacro_is_refused_with_a_hint():
    err = _error('<robot name="r" xmlns:xacro="http://ros.org/wiki/xacro">\n<xacro:macro name="m"/>\n</robot>')
    assert err.message.startswith("<string>:2: <xacro:macro> is xacro")
    assert "xacro" in err.hint


def test_unreadable_file_is_not_found(tmp_path):
    with pytest.raises(FleetError) as err:
        parse_urdf(tmp_path / "missing.urdf")
    assert err.value.code == ErrorCode.NOT_FOUND


def test_inertia_tensor_is_read_in_urdf_order():
    robot = parse_urdf(ARM.replace('ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>\n  </inertial>\n    <coll',
                                   'ixx="3" ixy="0.1" ixz="0.2" iyy="4" iyz="0.3" izz="5"/>\n  </inertial>\n'
                                   '    <coll'))
    inertial = robot.links["upper"].inertial
    assert inertial is not None
    np.testing.assert_array_equal(inertial.inertia.matrix(), [[3, 0.1, 0.2], [0.1, 4, 0.3], [0.2, 0.3, 5]])
