"""KISS-ICP scan-matching odometry on 2D lidar, with wheel odometry as the initial guess.

KISS-ICP 1.3's `KissICP.register_frame` always predicts with a constant-velocity model
(`last_pose @ last_delta`) and offers no initial-guess argument. This class composes the same KISS-ICP
building blocks (preprocessor, voxelisation, adaptive threshold, registration, voxel hash map) in the
same order, but takes the prediction from the wheel-odometry increment when there is one; without it,
it falls back to KISS-ICP's constant-velocity guess. Scans are planar: points get z = 0 and each
estimate is projected back onto SE(2) so roll, pitch and z cannot creep in.
"""

from __future__ import annotations

import numpy as np
from kiss_icp.config import KISSConfig
from kiss_icp.mapping import get_voxel_hash_map
from kiss_icp.preprocess import get_preprocessor
from kiss_icp.registration import get_registration
from kiss_icp.threshold import get_threshold_estimator
from kiss_icp.voxelization import voxel_down_sample

from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D
from slam import se2
from slam.types import OdometryStep


class KissOdometry:
    """Frame-to-local-map ICP; `register` returns the base_link pose in the odometry frame."""

    def __init__(self, *, voxel_size: float = 0.1, max_range: float = 10.0, min_range: float = 0.15,
                 max_points_per_voxel: int = 20, initial_threshold: float = 0.1, min_motion_th: float = 0.01,
                 max_iterations: int = 100, convergence: float = 1e-4) -> None:
        cfg = KISSConfig()
        cfg.data.max_range = max_range
        cfg.data.min_range = min_range
        cfg.data.deskew = False  # 2D scans arrive without per-point timestamps
        cfg.mapping.voxel_size = voxel_size
        cfg.mapping.max_points_per_voxel = max_points_per_voxel
        cfg.adaptive_threshold.initial_threshold = initial_threshold
        cfg.adaptive_threshold.min_motion_th = min_motion_th
        cfg.registration.max_num_iterations = max_iterations
        cfg.registration.convergence_criterion = convergence
        cfg.registration.max_num_threads = 1  # the machine is shared; one scan is ~400 points
        self._voxel_size = voxel_size
        self._preprocessor = get_preprocessor(cfg)
        self._threshold = get_threshold_estimator(cfg)
        self._registration = get_registration(cfg)
        self._local_map = get_voxel_hash_map(cfg)
        self._last_pose = np.eye(4)
        self._last_delta = np.eye(4)
        self.frames = 0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(*se2.from_matrix(self._last_pose))

    def register(self, points: np.ndarray, wheel_delta: se2.PoseTuple | None = None) -> OdometryStep:
        """Align one scan (n, 2 points in base_link); `wheel_delta` is the wheel-odometry motion since the
        previous scan, in the previous base_link frame."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        if len(pts) < 3:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a scan needs at least 3 valid returns, got {len(pts)}",
                             "check the lidar range limits")
        # 1. preprocess: range crop (no deskew) on planar points lifted to z = 0
        frame = self._preprocessor.preprocess(np.column_stack([pts, np.zeros(len(pts))]), np.zeros(0),
                                              np.eye(4))
        # 2. voxelize: a dense frame for the map, a sparser one to register
        frame_down = voxel_down_sample(frame, self._voxel_size * 0.5)
        source = voxel_down_sample(frame_down, self._voxel_size * 1.5)
        # 3. initial guess: wheel odometry if given, else constant velocity
        delta = se2.to_matrix4(wheel_delta) if wheel_delta is not None else self._last_delta
        guess = self._last_pose @ delta
        # 4. align to the local map (the first frame just seeds it)
        if self.frames == 0:
            new_pose = guess
        else:
            sigma = self._threshold.get_threshold()
            new_pose = self._registration.align_points_to_map(
                points=source, voxel_map=self._local_map, initial_guess=guess,
                max_correspondance_distance=3.0 * sigma, kernel=sigma)
            new_pose = se2.to_matrix4(se2.from_matrix(new_pose))  # back onto the plane
        # 5. update threshold, map, velocity and pose
        self._threshold.update_model_deviation(np.linalg.inv(guess) @ new_pose)
        self._local_map.update(frame_down, new_pose)
        step_delta = np.linalg.inv(self._last_pose) @ new_pose
        self._last_delta = step_delta
        self._last_pose = new_pose
        self.frames += 1
        return OdometryStep(pose=self.pose, delta=se2.from_matrix(step_delta), points_used=len(source))
