"""Sensor tools against closed forms: a lidar beam at a wall of known distance, wheel rates of a unicycle,
sensor mount transforms; camera and depth images as PNG content."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, image, ok

pytestmark = pytest.mark.anyio

WALL = """<sdf version="1.9"><model name="wall"><static>true</static><link name="l">
<collision name="c"><geometry><box><size>0.2 4 1.0</size></box></geometry></collision>
<visual name="v"><geometry><box><size>0.2 4 1.0</size></box></geometry></visual></link></model></sdf>"""


async def test_lidar_front_sector_reads_the_wall_distance(client, service: FleetService) -> None:
    await ok(client, "spawn_model", {"xml": WALL, "pose": {"x": 3.0, "y": 0.0, "z": 0.5}})
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.step(20)
    s = await ok(client, "read_sensor", {"robot": "r1", "sensor": "lidar"})
    front = next(x for x in s["data"]["sector_minima"] if x["sector"] == "front")
    assert front["min_range"] == pytest.approx(2.9, abs=0.04)  # wall face at x = 2.9, σ = 1 cm
    assert "ranges" not in s["data"] and s["data"]["beams"] == 360
    full = await ok(client, "read_sensor", {"robot": "r1", "sensor": "lidar", "response_format": "full"})
    ranges = np.array([np.inf if r is None else r for r in full["data"]["ranges"]])
    ahead = full["data"]["angle_min"] + full["data"]["angle_increment"] * np.arange(len(ranges))
    assert ranges[np.argmin(np.abs(ahead))] == pytest.approx(2.9, abs=0.04)


async def test_imu_odom_contact_and_pose_readings(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(1.0, 2.0, 0.3))
    await err(client, "read_sensor", {"robot": "r1", "sensor": "imu"}, "NOT_FOUND")  # nothing sampled yet
    service.step(10)
    imu = (await ok(client, "read_sensor", {"robot": "r1", "sensor": "imu"}))["data"]
    assert imu["linear_acceleration"][2] == pytest.approx(9.81, abs=0.1)  # the gravity reaction, standing still
    odom = (await ok(client, "read_sensor", {"robot": "r1", "sensor": "odom"}))["data"]
    assert odom["pose"] == {"x": 1.0, "y": 2.0, "yaw": 0.3} and odom["frame"] == "r1/odom"
    contact = (await ok(client, "read_sensor", {"robot": "r1", "sensor": "contact"}))["data"]
    assert contact["bumped"] is False
    pose = (await ok(client, "read_sensor", {"robot": "r1", "sensor": "pose"}))["data"]
    assert (pose["x"], pose["y"]) == (1.0, 2.0)
    await err(client, "read_sensor", {"robot": "r1", "sensor": "sonar"}, "INVALID_ARGUMENT")
    await err(client, "read_sensor", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_camera_and_depth_images(client, service: FleetService) -> None:
    await ok(client, "spawn_model", {"xml": WALL, "pose": {"x": 3.0, "y": 0.0, "z": 0.5}})
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    rgb, meta = await image(client, "get_camera_image", {"robot": "r1"})
    assert rgb.shape == (480, 640, 3) and meta["width"] == 640 and meta["intrinsics"]["fx"] == pytest.approx(
        320 / math.tan(math.radians(30)))
    depth, dmeta = await image(client, "get_camera_image", {"robot": "r1", "which": "depth"})
    assert depth.shape == (240, 320)
    # The camera sits on the chassis front (0.26 m ahead of base_link): the wall face is 2.9 − 0.26 m away.
    assert dmeta["depth"]["centre"] == pytest.approx(2.9 - 0.26, abs=0.02)
    assert dmeta["depth"]["min"] >= 0.5 - 0.02  # nothing nearer than the depth camera's range_min
    await err(client, "get_camera_image", {"robot": "r1", "which": "thermal"}, "INVALID_ARGUMENT")
    await err(client, "get_camera_image", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_joint_rates_follow_the_unicycle(client, service: FleetService) -> None:
    """ω_l,r = (v ∓ w·s/2) / r with s = 0.4 m, r = 0.1 m: v = 0.4, w = 0.5 → 3.0 and 5.0 rad/s."""
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.drive("r1", 0.4, 0.5, duration=3.0)
    service.advance(1.5)
    j = await ok(client, "get_joint_states", {"robot": "r1"})
    rates = {x["name"]: x["velocity"] for x in j["joints"]}
    assert rates["left_wheel_joint"] == pytest.approx(3.0, abs=0.01)
    assert rates["right_wheel_joint"] == pytest.approx(5.0, abs=0.01)
    assert all(x["position"] > 0 for x in j["joints"])
    await err(client, "get_joint_states", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_transforms_compose_the_sensor_mounts(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(1.0, 2.0, math.pi / 2))
    spec = service.world.robot_spec("r1")
    t = await ok(client, "get_transform", {"parent": "map", "child": "r1/lidar"})
    assert t["translation"] == pytest.approx([1.0, 2.0 + spec.mast.x_offset, spec.lidar_height], abs=1e-6)
    assert t["rpy"][2] == pytest.approx(math.pi / 2)
    cam = await ok(client, "get_transform", {"parent": "r1/base_link", "child": "r1/camera"})
    m = spec.camera_mount
    assert cam["translation"] == pytest.approx([m.x, m.y, m.z], abs=1e-6) and cam["quaternion"][3] == pytest.approx(1)
    odom = await ok(client, "get_transform", {"parent": "map", "child": "r1/odom"})
    assert odom["translation"] == pytest.approx([0, 0, 0], abs=1e-9)  # odom starts where map is
    frames = (await ok(client, "list_frames", {"robot": "r1"}))["frames"]
    assert "r1/lidar" in frames and "map" in frames
    await err(client, "get_transform", {"child": "r1/radar"}, "INVALID_ARGUMENT")
    await err(client, "get_transform", {"child": "nowhere"}, "NOT_FOUND")


async def test_list_sensors_filters_by_robot_and_type(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.spawn_robot("r2", Pose2D(2, 0, 0))
    all_ = (await ok(client, "list_sensors"))["sensors"]
    assert len(all_) == 12
    lidars = (await ok(client, "list_sensors", {"sensor_type": "lidar"}))["sensors"]
    assert [s["name"] for s in lidars] == ["r1/lidar", "r2/lidar"] and lidars[0]["beams"] == 360
    mine = (await ok(client, "list_sensors", {"robot": "r2", "sensor_type": "imu"}))["sensors"]
    assert [s["name"] for s in mine] == ["r2/imu"] and mine[0]["rate_hz"] == 100.0
    await err(client, "list_sensors", {"sensor_type": "gps"}, "INVALID_ARGUMENT")
    await err(client, "list_sensors", {"robot": "ghost"}, "UNKNOWN_ROBOT")
