"""On-demand RGB / depth / segmentation rendering (rendering every robot every frame is not affordable)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from sim.robot_spec import RobotSpec
from sim.types import CameraImage, Pose3D


def camera_mount(spec: RobotSpec) -> Pose3D:
    """Camera link pose in base_link (defined once, in RobotSpec.camera_mount)."""
    return spec.camera_mount


def render(client: int, robot: str, stamp: float, cam_pose: Pose3D, width: int, height: int, fov_deg: float,
           near: float, far: float, *, rgb: bool, depth: bool, segmentation: bool,
           depth_range: tuple[float, float] | None, depth_noise: float, rng: np.random.Generator) -> CameraImage:
    """Render from `cam_pose` (x forward, z up) with PyBullet's CPU renderer. `fov_deg` is horizontal, as in
    Gazebo and the course spec; PyBullet's projection takes the vertical FOV, derived here from the aspect."""
    m = cam_pose.matrix()
    eye = m[:3, 3]
    forward = m[:3, 0]
    up = m[:3, 2]
    view = p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), up.tolist(), physicsClientId=client)
    vfov = math.degrees(2 * math.atan(math.tan(math.radians(fov_deg) / 2) * height / width))
    proj = p.computeProjectionMatrixFOV(vfov, width / height, near, far, physicsClientId=client)
    flags = p.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX if segmentation else p.ER_NO_SEGMENTATION_MASK
    _, _, rgba, zbuf, seg = p.getCameraImage(width, height, view, proj, renderer=p.ER_TINY_RENDERER,
                                             flags=flags, physicsClientId=client)
    rgb_img = np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3].copy() if rgb else None
    depth_img = None
    if depth:
        z = np.reshape(np.asarray(zbuf, dtype=np.float64), (height, width))
        metric = far * near / (far - (far - near) * z)  # OpenGL depth buffer to metres along the optical axis
        if depth_noise > 0:
            metric = metric + rng.normal(0.0, depth_noise, metric.shape)
        lo, hi = depth_range if depth_range else (near, far)
        depth_img = np.where((metric >= lo) & (metric <= hi) & (z < 1.0), metric, np.inf).astype(np.float32)
    seg_img = np.reshape(np.asarray(seg, dtype=np.int64), (height, width)).astype(np.int32) if segmentation \
        else None
    return CameraImage(robot, stamp, width, height, fov_deg, rgb_img, depth_img, seg_img, cam_pose, near, far)


def camera_world_pose(x: float, y: float, yaw: float, mount: Pose3D) -> Pose3D:
    c, s = math.cos(yaw), math.sin(yaw)
    return Pose3D(x + c * mount.x - s * mount.y, y + s * mount.x + c * mount.y, mount.z, 0.0, mount.pitch, yaw)
