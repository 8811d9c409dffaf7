"""Foxglove messages from fleet state: transforms, poses, scans, the map grid, scene markers, log lines.

Frames follow REP-105 per robot namespace: `map → <ns>/odom → <ns>/base_link → <ns>/laser`. The map→odom
transform is what a perfect localiser would publish: ground truth composed with the inverse of the
(drifting) wheel odometry, so `map → base_link` is the true pose and `odom → base_link` the odometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CylinderPrimitive,
    FrameTransform,
    Grid,
    LaserScan,
    LinePrimitive,
    Log,
    LogLevel,
    PackedElementField,
    PackedElementFieldNumericType,
    Point3,
    Pose,
    PoseInFrame,
    Quaternion,
    SceneEntity,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    Vector2,
    Vector3,
)

from planning.grid import OccupancyGrid
from sim.transforms import se2_compose, se2_inverse
from sim.types import LidarScan, Pose2D

ROBOT_COLOUR = Color(r=1.0, g=0.5, b=0.0, a=0.9)
PATH_COLOUR = Color(r=0.1, g=0.5, b=0.9, a=1.0)
GOAL_COLOUR = Color(r=0.0, g=0.7, b=0.2, a=0.9)
HIT_COLOUR = Color(r=0.9, g=0.1, b=0.1, a=1.0)
LEVELS = {"collision": LogLevel.Error, "task_failed": LogLevel.Warning, "estop": LogLevel.Warning,
          "near_miss": LogLevel.Warning, "physics_unstable": LogLevel.Fatal, "sensor_fault": LogLevel.Warning,
          "low_battery": LogLevel.Warning}


def stamp(t: float) -> Timestamp:
    sec = math.floor(t)
    return Timestamp(sec=int(sec), nsec=round((t - sec) * 1e9) % 1_000_000_000)


def ns(t: float) -> int:
    return round(t * 1e9)


def _quat(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def pose_msg(x: float, y: float, yaw: float, z: float = 0.0) -> Pose:
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=_quat(yaw))


def _tf(t: float, parent: str, child: str, x: float, y: float, yaw: float, z: float = 0.0) -> FrameTransform:
    return FrameTransform(timestamp=stamp(t), parent_frame_id=parent, child_frame_id=child,
                          translation=Vector3(x=x, y=y, z=z), rotation=_quat(yaw))


def robot_transforms(t: float, ns_: str, truth: Pose2D, odom: Pose2D | None, laser: tuple[float, float]
                     ) -> list[FrameTransform]:
    """map→odom (truth ∘ odom⁻¹), odom→base_link (odometry), base_link→laser (mast offset, height)."""
    o = odom or truth
    m_o = se2_compose(truth.as_tuple(), se2_inverse(o.as_tuple()))
    return [_tf(t, "map", f"{ns_}/odom", *m_o), _tf(t, f"{ns_}/odom", f"{ns_}/base_link", o.x, o.y, o.yaw),
            _tf(t, f"{ns_}/base_link", f"{ns_}/laser", laser[0], 0.0, 0.0, laser[1])]


def pose_in_frame(t: float, p: Pose2D) -> PoseInFrame:
    return PoseInFrame(timestamp=stamp(t), frame_id="map", pose=pose_msg(p.x, p.y, p.yaw))


def scan_msg(scan: LidarScan, frame: str) -> LaserScan:
    r = np.where(np.isfinite(scan.ranges), scan.ranges, 0.0)  # Foxglove: 0 = no return
    end = scan.angle_min + scan.angle_increment * (len(r) - 1)
    return LaserScan(timestamp=stamp(scan.stamp), frame_id=frame, pose=pose_msg(0.0, 0.0, 0.0),
                     start_angle=scan.angle_min, end_angle=end, ranges=r.tolist())


def grid_msg(t: float, grid: OccupancyGrid) -> Grid:
    """Occupancy as uint8 0–100 (255 unknown), row-major from the lower-left cell (the map origin)."""
    data = np.where(grid.data < 0, 255, np.clip(grid.data, 0, 100)).astype(np.uint8)
    cols = data.shape[1]
    return Grid(timestamp=stamp(t), frame_id="map", pose=pose_msg(grid.origin[0], grid.origin[1], 0.0),
                column_count=cols, cell_size=Vector2(x=grid.resolution, y=grid.resolution),
                row_stride=cols, cell_stride=1,
                fields=[PackedElementField(name="occupancy", offset=0, type=PackedElementFieldNumericType.Uint8)],
                data=np.ascontiguousarray(data).tobytes())


def robot_entity(t: float, name: str, p: Pose2D, radius: float, in_collision: bool) -> SceneEntity:
    colour = HIT_COLOUR if in_collision else ROBOT_COLOUR
    return SceneEntity(
        timestamp=stamp(t), frame_id="map", id=f"robot/{name}",
        cylinders=[CylinderPrimitive(pose=pose_msg(p.x, p.y, p.yaw, 0.15), size=Vector3(x=2 * radius, y=2 * radius,
                                                                                      z=0.3),
                                     bottom_scale=1.0, top_scale=1.0, color=colour)],
        arrows=[ArrowPrimitive(pose=pose_msg(p.x, p.y, p.yaw, 0.32), shaft_length=radius, shaft_diameter=0.04,
                               head_length=0.12, head_diameter=0.1, color=colour)],
        texts=[TextPrimitive(pose=pose_msg(p.x, p.y, 0.0, 0.6), billboard=True, font_size=14.0, scale_invariant=True,
                             color=Color(r=1.0, g=1.0, b=1.0, a=1.0), text=name)])


def path_entity(t: float, name: str, path: np.ndarray, goal: Pose2D | None) -> SceneEntity:
    pts = [Point3(x=float(x), y=float(y), z=0.05) for x, y in np.asarray(path).reshape(-1, 2)]
    spheres = [] if goal is None else [SpherePrimitive(pose=pose_msg(goal.x, goal.y, 0.0, 0.1),
                                                       size=Vector3(x=0.25, y=0.25, z=0.25), color=GOAL_COLOUR)]
    return SceneEntity(timestamp=stamp(t), frame_id="map", id=f"path/{name}",
                       lines=[LinePrimitive(thickness=0.04, points=pts, color=PATH_COLOUR)] if len(pts) > 1 else [],
                       spheres=spheres)


def collision_entity(t: float, k: int, x: float, y: float) -> SceneEntity:
    return SceneEntity(timestamp=stamp(t), frame_id="map", id=f"collision/{k}",
                       spheres=[SpherePrimitive(pose=pose_msg(x, y, 0.0, 0.2), size=Vector3(x=0.35, y=0.35, z=0.35),
                                                color=HIT_COLOUR)])


def log_msg(t: float, kind: str, message: str, robots: Sequence[str]) -> Log:
    return Log(timestamp=stamp(t), level=LEVELS.get(kind, LogLevel.Info), message=message,
               name=f"{kind}" + (f" [{', '.join(robots)}]" if robots else ""))
