"""slam: scan-matching odometry (KISS-ICP), a GTSAM pose graph with verified loop closures, log-odds
occupancy mapping, localisation in a known map (AMCL-like + ICP), scan inputs (CARMEN, MCAP) and metrics.

Occupancy grids and map files are planning's (planning.grid.OccupancyGrid, planning.map_io); they are
re-exported here so SLAM users need one import.
"""

from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from slam.icp import IcpTarget, icp
from slam.io_carmen import CarmenLog, format_flaser, read_carmen
from slam.io_mcap import read_mcap_scans, write_mcap_scans
from slam.localization import Localizer
from slam.loop_closure import LoopCloser, ring_descriptor
from slam.mapping import OccupancyMapper
from slam.merge import merge_maps, relative_pose
from slam.metrics import align_se2, map_iou, match_by_stamp, trajectory_errors
from slam.odometry import KissOdometry
from slam.pipeline import SlamPipeline
from slam.pose_graph import PoseGraph
from slam.types import (
    IcpResult,
    Keyframe,
    KeyframeConfig,
    LocalizationConfig,
    LocalizationEstimate,
    LocalizationQuality,
    LoopClosure,
    LoopClosureConfig,
    MapIoU,
    MappingConfig,
    OdometryConfig,
    OdometryStep,
    PoseGraphConfig,
    ScanRecord,
    SlamConfig,
    SlamStatus,
    TrajectoryErrors,
)

__all__ = [
    "CarmenLog", "IcpResult", "IcpTarget", "Keyframe", "KeyframeConfig", "KissOdometry", "LocalizationConfig",
    "LocalizationEstimate", "LocalizationQuality", "Localizer", "LoopCloser", "LoopClosure", "LoopClosureConfig",
    "MapIoU", "MappingConfig", "OccupancyGrid", "OccupancyMapper", "OdometryConfig", "OdometryStep", "PoseGraph",
    "PoseGraphConfig", "ScanRecord", "SlamConfig", "SlamPipeline", "SlamStatus", "TrajectoryErrors", "align_se2",
    "format_flaser", "icp", "load_map", "map_iou", "match_by_stamp", "merge_maps", "read_carmen",
    "read_mcap_scans", "relative_pose", "ring_descriptor", "save_map", "trajectory_errors", "write_mcap_scans",
]
