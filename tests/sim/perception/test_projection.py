"""Camera geometry: the renderer's pixel convention, and lidar points projected onto closed-form pixels."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from PIL import Image

from sim.perception import (
    CameraIntrinsics,
    camera_in_lidar,
    camera_intrinsics,
    intrinsics_of,
    lidar_in_base,
    overlay_png,
    project_points,
    project_scan,
)
from sim.perception.projection import backproject, transform_points, valid_depth
from sim.robot_spec import RobotSpec
from sim.types import LidarScan, Pose3D
from tests.sim.perception.pb_scene import Scene

W, H, FOV = 160, 120, 60.0


def test_rendered_floor_back_projects_onto_z0_only_with_the_renderer_offset() -> None:
    s = Scene()
    try:
        s.add_ground()
        image = s.render(Pose3D(0.0, 0.0, 1.0, 0.0, math.radians(15), 0.0), W, H, FOV)
    finally:
        s.close()
    vv, uu = np.nonzero(valid_depth(image))
    d = np.asarray(image.depth, dtype=float)[vv, uu]
    rendered = transform_points(image.camera_pose, backproject(uu, vv, d, intrinsics_of(image)))
    ideal = transform_points(image.camera_pose,
                             backproject(uu, vv, d, CameraIntrinsics.from_fov(W, H, FOV)))
    assert np.abs(rendered[:, 2]).max() < 0.005  # the floor is z = 0 out to the far plane
    assert np.abs(ideal[:, 2]).max() > 0.05  # pixel-centre sampling would be visibly wrong


def test_intrinsics_from_the_sensor_model() -> None:
    spec = RobotSpec()
    k = camera_intrinsics(spec.sensors.camera, rendered=False)
    f = 320 / math.tan(math.radians(30))  # 640 px wide, 60° horizontal FOV
    assert (k.fx, k.fy, k.cx, k.cy) == pytest.approx((f, f, 319.5, 239.5))
    assert k.vertical_fov_deg == pytest.approx(2 * math.degrees(math.atan(240 / f)))
    kr = camera_intrinsics(spec.sensors.camera)
    assert (kr.cx, kr.cy) == (320.0, 239.0)


def _mount() -> tuple[Pose3D, Pose3D]:
    spec = RobotSpec()
    lidar = lidar_in_base(spec, base_height=0.0)
    cam = Pose3D(0.26, 0.0, 0.27)  # sim.World's camera mount for the default robot (front face, top)
    assert lidar.z == pytest.approx(spec.lidar_height)
    return lidar, cam


def test_lidar_point_lands_on_the_closed_form_pixel() -> None:
    lidar, cam = _mount()
    extr = camera_in_lidar(cam, lidar)
    k = CameraIntrinsics.from_fov(W, H, FOV)
    p_lidar = np.array([[3.0, 0.5, 0.0]])
    uv, depth, keep = project_points(p_lidar, extr, k)
    # Camera frame: forward 3 − 0.26, left 0.5, up lidar_height − 0.27.
    x, y, z = 3.0 - 0.26, 0.5, lidar.z - 0.27
    assert keep.tolist() == [0]
    assert depth[0] == pytest.approx(x)
    assert uv[0] == pytest.approx((k.cx - k.fx * y / x, k.cy - k.fy * z / x))


def test_projected_scan_beam_hits_the_rendered_marker() -> None:
    """A marker cube at the point a beam returns from must appear where the beam projects."""
    lidar, cam = _mount()
    base = Pose3D(1.0, -0.5, 0.0, 0.0, 0.0, math.radians(20))
    bearing, rng_ = math.radians(8.0), 3.0
    beams = 360
    ranges = np.full(beams, np.inf)
    i = round((bearing + math.pi) / (2 * math.pi / beams))
    ranges[i] = rng_
    scan = LidarScan("r", 0.0, -math.pi, 2 * math.pi / beams, 0.1, 10.0, ranges)
    a = scan.angles()[i]
    point_world = transform_points(base.compose(lidar), np.array([[rng_ * math.cos(a), rng_ * math.sin(a), 0]]))
    s = Scene()
    try:
        s.add_box("marker", Pose3D(*point_world[0]), (0.04, 0.04, 0.04))
        image = s.render(base.compose(cam), W, H, FOV)
    finally:
        s.close()
    png, proj = overlay_png(image, scan, camera_in_lidar(cam, lidar))
    assert proj.beams.tolist() == [i]
    vs, us = np.nonzero(np.asarray(image.segmentation) >= 0)
    assert us.size > 0
    # The marker's pixels surround the projection (its front face is 2 cm nearer: < 0.5 px here).
    assert proj.uv[0] == pytest.approx((us.mean(), vs.mean()), abs=0.6)
    drawn = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    u, v = (round(c) for c in proj.uv[0])
    assert image.rgb is not None
    assert not np.array_equal(drawn[v, u], image.rgb[v, u])  # a dot is drawn there


def test_points_behind_or_outside_the_camera_are_dropped() -> None:
    lidar, cam = _mount()
    k = CameraIntrinsics.from_fov(W, H, FOV)
    pts = np.array([[-3.0, 0.0, 0.0], [3.0, 10.0, 0.0], [3.0, 0.0, 0.0]])
    _, _, keep = project_points(pts, camera_in_lidar(cam, lidar), k)
    assert keep.tolist() == [2]
    empty = LidarScan("r", 0.0, -math.pi, 2 * math.pi / 8, 0.1, 10.0, np.full(8, np.inf))
    assert project_scan(empty, camera_in_lidar(cam, lidar), k).uv.shape == (0, 2)
