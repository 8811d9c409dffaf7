"""Lidar points projected into the camera image (lidar-camera overlay).

The extrinsics are the camera pose in the lidar frame. Either take them from the mount geometry
(`camera_in_lidar(camera_in_base, lidar_in_base)`, both from the robot model) or from the two sensors'
world poses at the same instant; then p_cam = T_cam⁻¹ · p_lidar, and the pinhole model of projection.py.
"""

from __future__ import annotations

import numpy as np

from sim.perception.drawing import draw_points
from sim.perception.projection import in_image, intrinsics_of, inverse_transform_points, project
from sim.perception.types import CameraIntrinsics, ScanProjection
from sim.robot_spec import RobotSpec
from sim.types import CameraImage, LidarScan, Pose2D, Pose3D


def lidar_in_base(spec: RobotSpec, base_height: float = 0.0) -> Pose3D:
    """The lidar frame in base_link: on the mast (x_offset), `spec.lidar_height` above the floor, with
    base_link `base_height` above the floor (sim.World's sensor poses put it on the floor); the lidar is
    not rotated (docs/world-api.md)."""
    return Pose3D(spec.mast.x_offset, 0.0, spec.lidar_height - base_height)


def camera_in_lidar(camera_in_base: Pose3D, lidar: Pose3D) -> Pose3D:
    """T_lidar_cam = T_base_lidar⁻¹ · T_base_cam (any common parent frame works, e.g. the world)."""
    return Pose3D.from_matrix(np.linalg.inv(lidar.matrix()) @ camera_in_base.matrix())


def extrinsics_from_image(image: CameraImage, robot_pose: Pose2D, spec: RobotSpec) -> Pose3D:
    """Camera pose in the lidar frame from the image's camera pose and the robot's (true) pose when it was
    rendered: T_lidar_cam = (T_robot · T_base_lidar)⁻¹ · T_world_cam."""
    lidar_world = Pose3D(robot_pose.x, robot_pose.y, 0.0, 0.0, 0.0, robot_pose.yaw).compose(lidar_in_base(spec))
    return camera_in_lidar(image.camera_pose, lidar_world)


def scan_points_3d(scan: LidarScan) -> tuple[np.ndarray, np.ndarray]:
    """Valid returns as (k, 3) points in the lidar frame (z = 0) and their beam indices."""
    beams = np.nonzero(np.isfinite(scan.ranges))[0]
    a = scan.angle_min + scan.angle_increment * beams
    r = scan.ranges[beams]
    return np.column_stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)]), beams


def project_points(points_lidar: np.ndarray, camera_in_lidar_pose: Pose3D, k: CameraIntrinsics,
                   min_depth: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lidar-frame points (n, 3) to (uv, depth, kept index) for those in front of and inside the image."""
    cam = inverse_transform_points(camera_in_lidar_pose, points_lidar)
    uv, depth = project(cam, k)
    keep = np.nonzero((depth > min_depth) & in_image(uv, k))[0]
    return uv[keep], depth[keep], keep


def project_scan(scan: LidarScan, camera_in_lidar_pose: Pose3D, k: CameraIntrinsics) -> ScanProjection:
    """The scan's returns that the camera sees, as pixels with their depth and beam index."""
    pts, beams = scan_points_3d(scan)
    uv, depth, keep = project_points(pts, camera_in_lidar_pose, k)
    return ScanProjection(uv, depth, beams[keep])


def overlay_png(image: CameraImage, scan: LidarScan, camera_in_lidar_pose: Pose3D) -> tuple[bytes,
                                                                                           ScanProjection]:
    """The camera image with the scan's returns drawn on it (colour = depth) as PNG, and the projection."""
    proj = project_scan(scan, camera_in_lidar_pose, intrinsics_of(image))
    return draw_points(image, proj.uv, proj.depth, max_depth=scan.range_max), proj
