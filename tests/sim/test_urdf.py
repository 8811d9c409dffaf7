"""The generated robot URDF, read back with sim.urdf_parser and checked against the spec it came from."""

import math
from pathlib import Path

import numpy as np
import pytest

from sim.robot_spec import RobotSpec, default_robot_path, load_robot_spec
from sim.types import Box, Cylinder, Pose3D, Sphere
from sim.urdf import FRAME_MASS, robot_frames, robot_urdf, write_robot_urdf
from sim.urdf_parser import parse_urdf

COMMITTED = Path(__file__).resolve().parents[2] / "configs" / "robots" / "diffbot.urdf"


@pytest.fixture(scope="module")
def spec():
    return load_robot_spec(default_robot_path())


@pytest.fixture(scope="module")
def robot(spec):
    return parse_urdf(robot_urdf(spec))


def test_committed_urdf_equals_the_generated_text(spec):
    assert COMMITTED.read_text(encoding="utf-8") == robot_urdf(spec), \
        "configs/robots/diffbot.urdf is stale: run `python -m sim.urdf`"


def test_generation_is_deterministic_and_writes_the_file(spec, tmp_path):
    out = write_robot_urdf(spec, tmp_path / "r.urdf")
    assert out.read_text(encoding="utf-8") == robot_urdf(spec) == robot_urdf(spec.model_copy(deep=True))


def test_chassis_is_the_spec_box_at_chassis_z(robot, spec):
    chassis = robot.links["chassis_link"]
    assert chassis.collisions[0].geometry == Box((0.5, 0.4, 0.2))
    poses = robot.link_poses()
    assert poses["chassis_link"].z == pytest.approx(spec.chassis_z)  # 0.15
    assert poses["chassis_link"].z - poses["left_wheel_link"].z == pytest.approx(spec.chassis_offset_z)
    assert robot.lowest_point("chassis_link") == pytest.approx(spec.chassis.ground_clearance)


def test_wheels_are_continuous_y_joints_with_radius_and_separation_of_the_spec(robot):
    for side in ("left", "right"):
        joint = robot.joints[f"{side}_wheel_joint"]
        assert (joint.type, joint.parent, joint.axis) == ("continuous", "base_link", (0.0, 1.0, 0.0))
        assert robot.links[joint.child].collisions[0].geometry == Cylinder(0.1, 0.05)
        assert joint.limit is not None and joint.limit.effort == 10.0
    assert robot.wheel_separation() == pytest.approx(0.4, abs=1e-12)
    assert robot.joints["left_wheel_joint"].origin.y == pytest.approx(0.2)  # left is +y (REP-103)


def test_wheels_and_caster_touch_the_floor_with_base_link_on_it(robot):
    base = Pose3D(1.0, -2.0, 0.0, yaw=0.7)  # on the floor anywhere, any heading
    for link in ("left_wheel_link", "right_wheel_link", "caster_link"):
        assert robot.lowest_point(link, base=base) == pytest.approx(0.0, abs=1e-9)
    assert robot.lowest_point(base=base) == pytest.approx(0.0, abs=1e-9)


def test_wheel_cylinder_axis_is_the_joint_axis(robot):
    """The visual/collision cylinder (URDF: along its z) must be rolled onto the link's y (the axle)."""
    shape = robot.links["left_wheel_link"].collisions[0]
    cylinder_axis = shape.origin.matrix()[:3, 2]
    np.testing.assert_allclose(np.abs(cylinder_axis), [0.0, 1.0, 0.0], atol=1e-9)


def test_caster_is_a_low_friction_sphere_on_a_fixed_joint(robot, spec):
    caster = robot.links["caster_link"]
    assert caster.collisions[0].geometry == Sphere(0.05)
    assert robot.joints["caster_joint"].type == "fixed"
    assert caster.contact is not None and caster.contact.lateral == pytest.approx(0.01)
    assert robot.link_poses()["caster_link"].x == pytest.approx(spec.caster.x_offset)
    assert caster.gazebo["mu1"] == caster.gazebo["mu2"] == "0.01"


def test_wheel_friction_for_pybullet_and_gazebo_comes_from_the_spec(robot):
    wheel = robot.links["left_wheel_link"]
    assert wheel.contact is not None
    assert (wheel.contact.lateral, wheel.contact.rolling, wheel.contact.spinning) == (1.0, 0.001, 0.001)
    assert wheel.gazebo["mu1"] == wheel.gazebo["mu2"] == "1"


def test_mast_is_0_3_m_and_the_lidar_sits_at_lidar_height(robot, spec):
    assert robot.links["mast_link"].collisions[0].geometry == Cylinder(0.025, 0.3)
    poses = robot.link_poses()
    mast_top = poses["mast_link"].z + 0.3 / 2
    assert mast_top == pytest.approx(spec.chassis_z + 0.1 + 0.3)
    assert poses["lidar_link"].z == pytest.approx(spec.lidar_height)  # 0.57


def test_total_mass_is_the_spec_mass_plus_one_gram_per_frame_link(robot, spec):
    frames = [n for n, link in robot.links.items() if not link.collisions]
    assert sorted(frames) == ["base_link", "camera_link", "camera_optical_link", "depth_camera_link",
                              "depth_camera_optical_link", "imu_link", "lidar_link"]
    assert robot.total_mass() == pytest.approx(spec.total_mass + FRAME_MASS * len(frames))
    assert robot.total_mass() == pytest.approx(5.0, abs=0.1)


def test_every_link_has_a_physical_inertial(robot):
    for link in robot.links.values():
        assert link.inertial is not None and link.inertial.mass > 0, link.name
        assert link.inertial.inertia.is_physical(), link.name


def test_collision_geometry_equals_visual_geometry_on_each_link(robot):
    for link in robot.links.values():
        assert [(c.geometry, c.origin) for c in link.collisions] == \
               [(v.geometry, v.origin) for v in link.visuals], link.name


def test_camera_optical_frame_looks_along_camera_x_with_x_right_and_y_down(robot):
    poses = robot.link_poses()
    cam, opt = poses["camera_link"].matrix()[:3, :3], poses["camera_optical_link"].matrix()[:3, :3]
    np.testing.assert_allclose(opt[:, 2], cam[:, 0], atol=1e-9)  # optical z = forward
    np.testing.assert_allclose(opt[:, 0], -cam[:, 1], atol=1e-9)  # optical x = right
    np.testing.assert_allclose(opt[:, 1], -cam[:, 2], atol=1e-9)  # optical y = down


def test_camera_frame_is_the_mount_the_simulator_renders_from(spec):
    from sim.sensors.camera import camera_mount

    mount, frame = camera_mount(spec), robot_frames(spec)["camera_link"]
    assert frame.position == pytest.approx(mount.position)
    assert frame.x > spec.chassis.size[0] / 2  # ahead of the chassis front face: the chassis is not in view


def test_diff_drive_plugin_matches_the_spec(robot):
    (drive,) = [p for p in robot.plugins if p.filename == "libgazebo_ros_diff_drive.so"]
    assert float(drive.param("update_rate") or 0) == 50
    assert float(drive.param("wheel_separation") or 0) == 0.4
    assert float(drive.param("wheel_diameter") or 0) == 0.2
    assert (drive.param("left_joint"), drive.param("right_joint")) == ("left_wheel_joint", "right_wheel_joint")
    assert drive.params_all("ros/remapping") == ["cmd_vel:=cmd_vel", "odom:=odom"]
    assert drive.param("robot_base_frame") == "base_link"


def test_sensors_match_the_spec(robot):
    sensors = {s.name: s for s in robot.sensors}
    lidar = sensors["lidar"]
    assert (lidar.type, lidar.link, lidar.update_rate, lidar.samples) == ("ray", "lidar_link", 10.0, 360)
    assert (lidar.range_min, lidar.range_max) == (0.1, 10.0)
    assert lidar.min_angle == pytest.approx(-math.pi)
    # Gazebo spaces beams by (max - min)/(samples - 1): that must be the simulator's 2π/360.
    assert (lidar.max_angle - lidar.min_angle) / 359 == pytest.approx(2 * math.pi / 360)
    cam = sensors["camera"]
    assert (cam.type, cam.image_width, cam.image_height, cam.update_rate) == ("camera", 640, 480, 30.0)
    assert cam.horizontal_fov == pytest.approx(math.radians(60))
    depth = sensors["depth_camera"]
    assert (depth.type, depth.image_width, depth.image_height) == ("depth", 320, 240)
    assert (depth.range_min, depth.range_max) == (0.5, 5.0)
    imu = sensors["imu"]
    assert (imu.type, imu.link, imu.update_rate, imu.noise_stddev) == ("imu", "imu_link", 100.0, 0.002)


def test_a_different_spec_gives_a_different_robot_that_still_stands_on_the_floor():
    spec = RobotSpec.model_validate({"wheels": {"radius": 0.15, "separation": 0.6, "mass": 1.0},
                                     "mast": {"height": 0.5}, "sensors": {"depth": {"enabled": False}}})
    robot = parse_urdf(robot_urdf(spec))
    assert robot.wheel_separation() == pytest.approx(0.6)
    assert robot.links["left_wheel_link"].collisions[0].geometry == Cylinder(0.15, 0.05)
    assert robot.lowest_point("left_wheel_link") == pytest.approx(0.0, abs=1e-9)
    assert robot.lowest_point("caster_link") == pytest.approx(0.0, abs=1e-9)
    assert robot.link_poses()["lidar_link"].z == pytest.approx(spec.lidar_height)
    assert robot.total_mass() == pytest.approx(spec.total_mass + 7 * FRAME_MASS)
    assert "depth_camera" not in {s.name for s in robot.sensors}
