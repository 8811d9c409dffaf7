"""Perception services over sim readings (no PyBullet here): camera segmentation and detection, lidar and
depth-cloud processing, an odometry/IMU EKF, lidar-camera overlays, sensor health and calibration.

See docs/perception.md.
"""

from sim.perception.calibration import camera_intrinsics, estimate_imu_bias, estimate_lidar_offset
from sim.perception.detection import detect_objects
from sim.perception.drawing import annotate_detections, label_map_png
from sim.perception.ekf import Ekf, make_ekf
from sim.perception.ground import fit_ground_plane, ground_by_height, remove_ground
from sim.perception.health import StreamMonitor, make_stream_monitor
from sim.perception.lidar_processing import (
    cluster_obstacles,
    sector_minima,
    statistical_outlier_removal,
    voxel_filter,
)
from sim.perception.map_outline import map_outline
from sim.perception.overlay import (
    camera_in_lidar,
    extrinsics_from_image,
    lidar_in_base,
    overlay_png,
    project_points,
    project_scan,
)
from sim.perception.projection import backproject, depth_to_points, intrinsics_of, project
from sim.perception.segmentation import decode_mask, label_pixels
from sim.perception.sensor_monitor import SensorHealthMonitor, reading_values, stream_configs
from sim.perception.types import (
    CameraIntrinsics,
    Detection,
    EkfConfig,
    EkfState,
    GroundPlane,
    HealthAlert,
    ImuBias,
    Labeler,
    LabelMap,
    LidarOffsetEstimate,
    Obstacle,
    ScanProjection,
    SectorMinimum,
    StreamConfig,
    StreamHealth,
)

__all__ = [
    "CameraIntrinsics",
    "Detection",
    "Ekf",
    "EkfConfig",
    "EkfState",
    "GroundPlane",
    "HealthAlert",
    "ImuBias",
    "LabelMap",
    "Labeler",
    "LidarOffsetEstimate",
    "Obstacle",
    "ScanProjection",
    "SectorMinimum",
    "SensorHealthMonitor",
    "StreamConfig",
    "StreamHealth",
    "StreamMonitor",
    "annotate_detections",
    "backproject",
    "camera_in_lidar",
    "camera_intrinsics",
    "cluster_obstacles",
    "decode_mask",
    "depth_to_points",
    "detect_objects",
    "estimate_imu_bias",
    "estimate_lidar_offset",
    "extrinsics_from_image",
    "fit_ground_plane",
    "ground_by_height",
    "intrinsics_of",
    "label_map_png",
    "label_pixels",
    "lidar_in_base",
    "make_ekf",
    "make_stream_monitor",
    "map_outline",
    "overlay_png",
    "project",
    "project_points",
    "project_scan",
    "reading_values",
    "remove_ground",
    "sector_minima",
    "statistical_outlier_removal",
    "stream_configs",
    "voxel_filter",
]
