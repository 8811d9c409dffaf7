"""Perception on sim.World's own sensors: camera detection, dropout injection, biased IMU, lidar offset."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from sim import Pose2D, RobotSpec, World
from sim.perception import (
    SensorHealthMonitor,
    depth_to_points,
    detect_objects,
    estimate_imu_bias,
    estimate_lidar_offset,
    extrinsics_from_image,
    intrinsics_of,
    label_pixels,
    map_outline,
    project_scan,
)
from sim.types import ImuReading

CRATE = """<sdf version="1.9"><model name="crate"><static>true</static><pose>3 0.3 0.5 0 0 0</pose>
<link name="link"><collision name="c"><geometry><box><size>0.6 0.6 1.0</size></box></geometry></collision>
<visual name="v"><geometry><box><size>0.6 0.6 1.0</size></box></geometry></visual></link></model></sdf>"""
WALL = """<sdf version="1.9"><model name="wall_{i}"><static>true</static><pose>{x} {y} 0.5 0 0 {yaw}</pose>
<link name="link"><collision name="c"><geometry><box><size>6 0.2 1.0</size></box></geometry></collision>
<visual name="v"><geometry><box><size>6 0.2 1.0</size></box></geometry></visual></link></model></sdf>"""


@pytest.fixture()
def world() -> Iterator[World]:
    w = World(seed=3)
    w.spawn_model(xml=CRATE)
    yield w
    w.close()


def test_world_camera_detects_the_crate_at_its_true_place(world: World) -> None:
    world.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    image = world.render_camera("r1")
    dets = detect_objects(image, world.body_label, exclude=("ground_plane", "r1"))
    assert [d.label for d in dets] == ["crate"]
    d = dets[0]
    # Face-on front face at x = 2.7: depth = 2.7 − camera x; median point on the face, y in the crate's span.
    assert d.distance == pytest.approx(2.7 - image.camera_pose.x, abs=0.005)
    assert d.position is not None and d.position[0] == pytest.approx(2.7, abs=0.005)
    assert 0.0 <= d.position[1] <= 0.6 and 0.0 <= d.position[2] <= 1.0
    assert image.segmentation is not None and image.depth is not None
    lm = label_pixels(image.segmentation, world.body_label)
    floor = depth_to_points(image)[lm.ids[np.isfinite(image.depth)] == lm.labels.index(("ground_plane", "link"))]
    assert np.abs(floor[:, 2]).max() < 0.005  # the floor back-projects onto z = 0


def test_injected_lidar_dropout_is_flagged_within_one_second(world: World) -> None:
    world.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    mon = SensorHealthMonitor()
    mon.add_robot("r1", world.robot_spec("r1"))
    mon.attach(world)
    world.run_for(2.5)
    assert mon.alerts(world.time) == []
    t_fault = world.time
    world.set_sensor_fault("r1", "lidar", dropout=True)
    flagged = None
    while world.time - t_fault < 2.0:
        world.step()
        if any(a.kind == "dropout" for a in mon.report(world.time, "r1/scan")["r1/scan"].alerts):
            flagged = world.time
            break
    assert flagged is not None and flagged - t_fault <= 1.0
    assert all(a.stream == "r1/scan" for a in mon.alerts(world.time))  # the other streams are fine


def test_biased_world_imu_is_calibrated_within_ten_percent(world: World) -> None:
    accel, gyro = (0.05, -0.03, 0.08), (0.004, -0.006, 0.01)
    spec = RobotSpec.model_validate({"sensors": {"imu": {"accel_bias": list(accel), "gyro_bias": list(gyro)}}})
    world.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0), spec=spec)
    imu: list[ImuReading] = []
    world.subscribe(lambda r: imu.append(r) if isinstance(r, ImuReading) else None, kinds=("imu",))
    world.run_for(2.0)
    est = estimate_imu_bias(imu)
    for got, want in zip((*est.accel, *est.gyro), (*accel, *gyro), strict=True):
        assert got == pytest.approx(want, rel=0.1)


def test_lidar_mast_offset_is_recovered_from_world_scans(world: World) -> None:
    for i, (x, y, yaw) in enumerate([(0, 3, 0), (0, -3, 0), (3.1, 0, math.pi / 2), (-3.1, 0, math.pi / 2)]):
        world.spawn_model(xml=WALL.format(i=i, x=x, y=y, yaw=yaw))
    spec = RobotSpec.model_validate({"mast": {"x_offset": 0.08}})
    world.spawn_robot("r1", Pose2D(-1.5, 1.0, 0.4), spec=spec)
    scans = []
    for pose in (Pose2D(-1.5, 1.0, 0.4), Pose2D(1.0, -1.5, 2.0), Pose2D(-1.0, -1.8, -1.2)):
        world.set_robot_pose("r1", pose)
        world.run_for(0.11)
        scan = world.latest_scan("r1")
        assert scan is not None
        scans.append((scan, world.robot_pose("r1")))
    pts, normals = map_outline(world.description, spec.lidar_height)
    est = estimate_lidar_offset(scans, pts, normals, truth=Pose2D(0.08, 0.0, 0.0))
    assert est.error_xy is not None and est.error_xy < 0.01
    assert est.error_yaw is not None and est.error_yaw < math.radians(0.3)


def test_world_scan_projects_onto_the_crate_pixels(world: World) -> None:
    world.spawn_robot("r1", Pose2D(0.0, 0.0, 0.1))
    world.run_for(0.11)
    scan, image = world.latest_scan("r1"), world.render_camera("r1")
    assert scan is not None and scan.hit_bodies is not None and image.segmentation is not None
    proj = project_scan(scan, extrinsics_from_image(image, world.robot_pose("r1"), world.robot_spec("r1")),
                        intrinsics_of(image))
    crate_beams = [b for b in proj.beams if world.body_label(int(scan.hit_bodies[b]))[0] == "crate"]
    assert len(crate_beams) > 10
    lm = label_pixels(image.segmentation, world.body_label)
    on_crate = lm.model_mask("crate")
    uv = np.rint(proj.uv[np.isin(proj.beams, crate_beams)]).astype(int)
    assert on_crate[uv[:, 1], uv[:, 0]].mean() > 0.95  # each crate return lands on a crate pixel
