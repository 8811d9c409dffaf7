"""A tiny PyBullet scene for perception tests: boxes at known places, rendered the way sim.World renders.

Ground truth comes from the scene definition (box poses and sizes), never from the code under test.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pybullet as p

from sim.types import CameraImage, Pose3D


def vertical_fov(hfov_deg: float, width: int, height: int) -> float:
    """PyBullet's projection takes the vertical FOV; cameras here are specified by the horizontal one."""
    return math.degrees(2 * math.atan(math.tan(math.radians(hfov_deg) / 2) * height / width))


class Scene:
    def __init__(self) -> None:
        self.client = p.connect(p.DIRECT)
        self.names: dict[int, tuple[str, dict[int, str]]] = {}
        self.boxes: dict[str, tuple[Pose3D, tuple[float, float, float]]] = {}

    def close(self) -> None:
        p.disconnect(physicsClientId=self.client)

    def add_ground(self) -> int:
        col = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=self.client)
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=[50, 50, 0.0005], visualFramePosition=[0, 0, -0.0005],
                                  physicsClientId=self.client)
        uid = p.createMultiBody(0, col, vis, physicsClientId=self.client)
        self.names[uid] = ("ground_plane", {-1: "link"})
        return uid

    def add_box(self, name: str, pose: Pose3D, size: tuple[float, float, float],
                rgba: tuple[float, float, float, float] = (0.8, 0.3, 0.2, 1.0)) -> int:
        half = [s / 2 for s in size]
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=list(rgba), physicsClientId=self.client)
        uid = p.createMultiBody(0, col, vis, basePosition=pose.position, baseOrientation=pose.quaternion,
                                physicsClientId=self.client)
        self.names[uid] = (name, {-1: "base"})
        self.boxes[name] = (pose, size)
        return uid

    def add_two_link(self, name: str, base: tuple[float, float, float], size: float) -> int:
        """A base cube with a second cube stacked on it as link 0 (named 'top')."""
        half = [size / 2] * 3
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        uid = p.createMultiBody(0, col, vis, basePosition=base, linkMasses=[0.0], linkCollisionShapeIndices=[col],
                                linkVisualShapeIndices=[vis], linkPositions=[[0, 0, size]],
                                linkOrientations=[[0, 0, 0, 1]], linkInertialFramePositions=[[0, 0, 0]],
                                linkInertialFrameOrientations=[[0, 0, 0, 1]], linkParentIndices=[0],
                                linkJointTypes=[p.JOINT_FIXED], linkJointAxis=[[0, 0, 1]],
                                physicsClientId=self.client)
        self.names[uid] = (name, {-1: "base", 0: "top"})
        return uid

    def labeler(self, uid: int, link: int) -> tuple[str, str]:
        name, links = self.names.get(uid, ("", {}))
        return (name, links.get(link, ""))

    def render(self, pose: Pose3D, width: int = 160, height: int = 120, fov_deg: float = 60.0,
               near: float = 0.05, far: float = 30.0, link_flag: bool = True) -> CameraImage:
        """Render like sim/sensors/camera.py: x-forward camera link, horizontal FOV, z-buffer depth in metres."""
        m = pose.matrix()
        eye, fwd, up = m[:3, 3], m[:3, 0], m[:3, 2]
        view = p.computeViewMatrix(eye.tolist(), (eye + fwd).tolist(), up.tolist(), physicsClientId=self.client)
        proj = p.computeProjectionMatrixFOV(vertical_fov(fov_deg, width, height), width / height, near, far,
                                            physicsClientId=self.client)
        flags = p.ER_SEGMENTATION_MASK_OBJECT_AND_LINKINDEX if link_flag else 0
        _, _, rgba, zbuf, seg = p.getCameraImage(width, height, view, proj, renderer=p.ER_TINY_RENDERER,
                                                 flags=flags, physicsClientId=self.client)
        z = np.reshape(np.asarray(zbuf, dtype=float), (height, width))
        metric = far * near / (far - (far - near) * z)
        depth = np.where(z < 1.0, metric, np.inf).astype(np.float32)
        rgb = np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3].copy()
        mask = np.reshape(np.asarray(seg, dtype=np.int64), (height, width)).astype(np.int32)
        return CameraImage("cam", 0.0, width, height, fov_deg, rgb, depth, mask, pose, near, far)


def box_corners(pose: Pose3D, size: tuple[float, float, float]) -> np.ndarray:
    half = np.asarray(size) / 2
    c = np.array(list(itertools.product((-1, 1), repeat=3))) * half
    m = pose.matrix()
    return c @ m[:3, :3].T + m[:3, 3]


def distance_to_box(points: np.ndarray, pose: Pose3D, size: tuple[float, float, float]) -> np.ndarray:
    """Unsigned distance of world points to the box surface (closed form in the box frame)."""
    m = pose.matrix()
    local = (points - m[:3, 3]) @ m[:3, :3]
    q = np.abs(local) - np.asarray(size) / 2
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return np.abs(outside + inside)


def gl_project(points: np.ndarray, pose: Pose3D, width: int, height: int, fov_deg: float,
               near: float = 0.05, far: float = 30.0) -> np.ndarray:
    """Pixel (u, v) of world points through PyBullet's own OpenGL view and projection matrices (the
    renderer's ground truth; pixel centres on integers, v down)."""
    m = pose.matrix()
    eye, fwd, up = m[:3, 3], m[:3, 0], m[:3, 2]
    view = np.asarray(p.computeViewMatrix(eye.tolist(), (eye + fwd).tolist(), up.tolist())).reshape(4, 4).T
    vfov = vertical_fov(fov_deg, width, height)
    proj = np.asarray(p.computeProjectionMatrixFOV(vfov, width / height, near, far)).reshape(4, 4).T
    h = np.column_stack([points, np.ones(len(points))])
    clip = h @ (proj @ view).T
    ndc = clip[:, :3] / clip[:, 3:4]
    return np.column_stack([(ndc[:, 0] + 1) / 2 * width - 0.5, (1 - ndc[:, 1]) / 2 * height - 0.5])
