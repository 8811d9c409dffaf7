"""Pinhole camera geometry on the camera link frame (x forward, y left, z up) used across perception.

A point (X, Y, Z) in the camera frame lands on u = cx − fx·Y/X, v = cy − fy·Z/X with depth X; that is the
usual optical-frame projection after (x_opt, y_opt, z_opt) = (−Y, −Z, X).
"""

from __future__ import annotations

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.perception.types import CameraIntrinsics
from sim.types import CameraImage, Pose3D

# PyBullet's TinyRenderer (the one sim.World uses) samples each pixel at its corner, not its centre:
# rendered pixel (i, j) shows the ideal pinhole's (i − ½, j + ½). Measured in
# tests/sim/perception/test_projection.py; without it a floor 10 m away back-projects ≈ 6 cm too high
# at 120×90. It shifts the principal point to (w/2, h/2 − 1).
TINY_RENDERER_OFFSET = (0.5, -0.5)


def intrinsics_of(image: CameraImage) -> CameraIntrinsics:
    """The intrinsics that hold for `image` as sim.World renders it (TinyRenderer pixel convention)."""
    return CameraIntrinsics.from_fov(image.width, image.height, image.fov_deg, TINY_RENDERER_OFFSET)


def transform_points(pose: Pose3D, points: np.ndarray) -> np.ndarray:
    """Points (n, 3) given in `pose`'s frame, returned in its parent frame."""
    m = pose.matrix()
    return np.asarray(points, dtype=float) @ m[:3, :3].T + m[:3, 3]


def inverse_transform_points(pose: Pose3D, points: np.ndarray) -> np.ndarray:
    """Points (n, 3) given in `pose`'s parent frame, returned in `pose`'s frame."""
    m = pose.matrix()
    return (np.asarray(points, dtype=float) - m[:3, 3]) @ m[:3, :3]


def project(points_cam: np.ndarray, k: CameraIntrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Camera-frame points (n, 3) to pixel coordinates (n, 2) (float, u right, v down) and depth (n,).

    Points at or behind the camera get NaN pixels; callers filter by depth and image bounds."""
    p = np.asarray(points_cam, dtype=float).reshape(-1, 3)
    depth = p[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(depth > 1e-9, 1.0 / depth, np.nan)
    uv = np.column_stack([k.cx - k.fx * p[:, 1] * inv, k.cy - k.fy * p[:, 2] * inv])
    return uv, depth


def in_image(uv: np.ndarray, k: CameraIntrinsics) -> np.ndarray:
    """True where a projected pixel centre falls inside the image (pixel i covers [i − ½, i + ½))."""
    u, v = uv[:, 0], uv[:, 1]
    with np.errstate(invalid="ignore"):
        return (u >= -0.5) & (u < k.width - 0.5) & (v >= -0.5) & (v < k.height - 0.5)


def backproject(u: np.ndarray, v: np.ndarray, depth: np.ndarray, k: CameraIntrinsics) -> np.ndarray:
    """Pixels with their depth (metres along the camera x axis) to camera-frame points (n, 3)."""
    d = np.asarray(depth, dtype=float)
    return np.column_stack([d, -(np.asarray(u, dtype=float) - k.cx) * d / k.fx,
                            -(np.asarray(v, dtype=float) - k.cy) * d / k.fy])


def valid_depth(image: CameraImage) -> np.ndarray:
    """Boolean (h, w) mask of depth pixels holding a real return (finite, inside [near, far])."""
    if image.depth is None:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "the camera image has no depth channel",
                         "render it with depth=True")
    d = np.asarray(image.depth)
    with np.errstate(invalid="ignore"):
        return np.isfinite(d) & (d >= image.near) & (d < image.far)


def depth_to_points(image: CameraImage, stride: int = 1, frame: str = "world") -> np.ndarray:
    """The depth image as a point cloud (k, 3) in the world (or `frame="camera"`), every `stride` pixels."""
    if stride < 1 or frame not in ("world", "camera"):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"bad stride {stride} or frame {frame!r}",
                         "stride ≥ 1; frame is 'world' or 'camera'")
    ok = valid_depth(image)[::stride, ::stride]
    vv, uu = np.nonzero(ok)
    vv, uu = vv * stride, uu * stride
    assert image.depth is not None  # checked by valid_depth
    pts = backproject(uu, vv, np.asarray(image.depth)[vv, uu], intrinsics_of(image))
    return pts if frame == "camera" else transform_points(image.camera_pose, pts)
