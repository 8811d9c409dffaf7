"""Robots from URDF and xacro: the drive, limits, sensors and mounts come from the description (closed-form
checks against the published dimensions written into tests/sim/data), missing values are reported, and the
robots drive in PyBullet as their geometry says."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from sim import Pose2D, World
from sim.errors import FleetError
from sim.resources import shipped
from sim.robot_load import load_robot_model
from sim.robot_spec import load_robot_spec

DATA = Path(__file__).parent / "data"
COURSE = shipped("robots", "course_robot.urdf")
JACKAL = DATA / "robots" / "jackal_like.urdf"
TB3 = DATA / "packages" / "tb3_like_description" / "urdf" / "tb3_like.urdf.xacro"


@pytest.fixture(autouse=True)
def package_path(monkeypatch):
    monkeypatch.setenv("FLEETNAV_PACKAGE_PATH", str(DATA / "packages"))


def test_course_robot_matches_the_assignment_and_the_yaml_robot():
    loaded = load_robot_model(COURSE)
    s, yaml_spec = loaded.spec, load_robot_spec(shipped("robots", "diffbot.yaml"))
    assert (s.wheels.radius, s.wheels.separation) == (0.1, 0.4)  # <wheel_diameter> / 2, <wheel_separation>
    assert s.sensors.odometry.rate_hz == 50
    lid = s.sensors.lidar
    assert (lid.beams, lid.fov_deg, lid.rate_hz, lid.range_min, lid.range_max) == (360, 360.0, 10, 0.1, 10.0)
    assert lid.noise_std == 0.01
    cam = s.sensors.camera
    assert (cam.width, cam.height, cam.rate_hz) == (640, 480, 30) and cam.fov_deg == pytest.approx(60.0)
    assert (s.sensors.depth.range_min, s.sensors.depth.range_max) == (0.5, 5.0)
    assert (s.sensors.imu.rate_hz, s.sensors.imu.gyro_noise_std, s.sensors.imu.accel_noise_std) == (100, 0.002, 0.02)
    # Mounts from the description: base_link is 0.15 m below the file's base_link (the chassis centre).
    assert s.lidar_height == pytest.approx(0.15 + 0.25 + 0.17) == pytest.approx(yaml_spec.lidar_height)
    assert s.camera_mount.position == pytest.approx(yaml_spec.camera_mount.position)
    assert s.total_mass == pytest.approx(5.003, abs=0.01)
    assert s.footprint_radius == pytest.approx(math.hypot(0.25, 0.225))
    # The assignment's plugin block gives no limits or torque: each default is reported, none is silent.
    assert any("max linear speed not given" in w for w in loaded.warnings)
    assert any("max wheel torque" in w for w in loaded.warnings)
    assert s.limits == yaml_spec.limits


def test_turtlebot3_like_xacro_with_package_uris():
    loaded = load_robot_model(TB3)
    s = loaded.spec
    assert (s.wheels.radius, s.wheels.separation, s.wheels.width) == (0.033, 0.16, 0.018)
    assert s.wheels.left_joints == ("wheel_left_joint",) and s.wheels.max_torque == 20
    # base_footprint is already on the floor under the axle: the lidar is 0.010 + 0.172 m up, 0.032 m back.
    assert s.lidar_height == pytest.approx(0.182)
    assert s.sensors.lidar.mount == pytest.approx((-0.032, 0.0, 0.182))
    assert s.mast.x_offset == pytest.approx(-0.032)  # where the 2D lidar casts from
    lid = s.sensors.lidar
    assert (lid.beams, lid.fov_deg, lid.rate_hz, lid.range_min, lid.range_max) == (360, 360.0, 5, 0.12, 3.5)
    # max_wheel_acceleration 1.0 m/s² at the rim: linear 1.0, angular 2·1.0/0.16.
    assert s.limits.max_linear_accel == 1.0 and s.limits.max_angular_accel == pytest.approx(12.5)
    assert not s.sensors.camera.enabled and "no camera sensor: the RGB camera is disabled" in loaded.warnings
    assert s.sensors.imu.rate_hz == 200
    assert any("imu 'tb3_imu': no angular_velocity" in w for w in loaded.warnings)
    text = Path(s.description or "").read_text()
    assert str(DATA / "packages" / "tb3_like_description" / "meshes" / "lds.stl") in text  # package:// resolved


def test_jackal_like_gz_sim_plugin_four_wheels_and_sensor_pose():
    loaded = load_robot_model(JACKAL)
    s = loaded.spec
    assert s.wheels.left_joints == ("front_left_wheel", "rear_left_wheel")
    assert (s.wheels.radius, s.wheels.separation) == (0.098, 0.37559)
    assert (s.limits.max_linear, s.limits.max_angular, s.limits.max_linear_accel) == (2.0, 4.0, 20.0)
    # Lidar: mid mount 0.184 m over base_link, sensor <pose> 0.12 forward 0.05 up, base_link 0.0635 up.
    assert s.sensors.lidar.mount == pytest.approx((0.12, 0.0, 0.184 + 0.05 + 0.098 - 0.0345))
    lid = s.sensors.lidar
    assert lid.beams == 1081 and lid.fov_deg == pytest.approx(math.degrees(2 * 2.35619) * 1081 / 1080)
    assert s.sensors.odometry.rate_hz == 50
    assert any("max wheel torque" in w for w in loaded.warnings)


def test_missing_package_and_bad_descriptions_are_clear_errors(monkeypatch, tmp_path):
    monkeypatch.setenv("FLEETNAV_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(FleetError, match=r"\$\(find tb3_like_description\): no package 'tb3_like_description'"):
        load_robot_model(TB3)
    mesh = TB3.parent.parent / "meshes" / "lds.stl"
    urdf = COURSE.read_text().replace('<link name="mast">', '<link name="mast"><visual><geometry><mesh '
                                      'filename="package://nopkg/meshes/lds.stl"/></geometry></visual>')
    with pytest.raises(FleetError, match=re.escape("cannot find package 'nopkg' of 'package://nopkg/meshes/lds.stl'")):
        load_robot_model(urdf)
    assert mesh.is_file()
    no_drive = ('<robot name="r"><link name="a"><collision><geometry><box size="1 1 1"/></geometry></collision>'
                "</link></robot>")
    with pytest.raises(FleetError, match="no differential drive"):
        load_robot_model(no_drive)
    bad_joint = COURSE.read_text().replace("<left_joint>left_wheel_joint</left_joint>", "<left_joint>nope</left_joint>")
    with pytest.raises(FleetError, match="wheel joint 'nope' is not defined"):
        load_robot_model(bad_joint)
    with pytest.raises(FleetError, match="no such file"):
        load_robot_model(tmp_path / "missing.urdf")


@pytest.mark.parametrize("source", [COURSE, TB3, JACKAL], ids=["course", "tb3", "jackal"])
def test_dynamic_robot_rests_on_its_wheels_and_drives_a_closed_form_line(source):
    spec = load_robot_model(source).spec
    world = World(physics_hz=240)
    try:
        world.spawn_robot("r", Pose2D(0.0, 0.0, 0.0), spec=spec, fidelity="dynamic")
        world.step(120)  # settle
        start = world.robot_pose("r")
        v = min(0.4, spec.limits.max_linear)
        world.set_cmd_vel("r", v, 0.0)
        world.step(3 * 240)
        end = world.robot_pose("r")
        # Ramp-up at the acceleration limit costs v²/(2a) of distance against v·t.
        expected = v * 3.0 - v * v / (2 * spec.limits.max_linear_accel)
        assert math.hypot(end.x - start.x, end.y - start.y) == pytest.approx(expected, rel=0.1)
        # The TurtleBot3-like robot rocks back onto its box caster (its centre of mass is behind the axle) and
        # veers a little; the others hold their heading.
        assert abs(end.yaw - start.yaw) < (0.15 if source == TB3 else 0.01)
    finally:
        world.close()


def test_kinematic_urdf_robot_blocks_on_its_own_collision_shapes():
    spec = load_robot_model(COURSE).spec
    world = World(physics_hz=100)
    try:
        world.spawn_robot("r", Pose2D(0.0, 0.0, 0.0), spec=spec, fidelity="kinematic")
        world.spawn_robot("s", Pose2D(0.8, 0.0, 0.0), spec=spec, fidelity="kinematic")
        with pytest.raises(FleetError, match="overlaps"):  # chassis 0.5 m long: 0.4 m apart overlaps
            world.spawn_robot("t", Pose2D(0.0, 0.4, math.pi / 2), spec=spec, fidelity="kinematic")
    finally:
        world.close()
