"""Perception tools (the "advanced sensors"): object detection and segmentation on a camera image rendered
now, lidar–camera fusion overlay, scan/depth-cloud processing, odometry+IMU fusion (EKF), sensor health,
calibration against ground truth."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from mcp.server.mcpserver import Context
from mcp_types import CallToolResult
from pydantic import Field

from mcp_server.app import app_of, run
from mcp_server.imaging import image_result
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer
from mcp_server.waiting import advance
from sim.perception.types import EkfConfig


class Detections(Answer):
    robot: str
    detections: list[dict[str, Any]]
    image: dict[str, Any]


class Segmentation(Answer):
    robot: str
    classes: list[dict[str, Any]]
    background_fraction: float
    image: dict[str, Any]


class Overlay(Answer):
    robot: str
    returns: int
    projected: int = Field(description="lidar returns that land inside the image")
    scan_stamp: float
    depth_range: list[float | None] | None
    image: dict[str, Any]


class Result(Answer):
    result: dict[str, Any]


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="Detect objects in view")
    async def detect_objects(ctx: Context, robot: str, min_pixels: int = Field(20, ge=1, le=100_000),
                             group_by: Literal["model", "link"] = "model") -> Annotated[CallToolResult, Detections]:
        """Render the robot's camera and detect every visible model: box (pixels), pixel count, distance and
        world position; the annotated image is returned too."""
        svc = app_of(ctx).service
        d = await run(ctx, svc.detect_objects, robot, min_pixels=min_pixels, group_by=group_by)
        meta = Detections(sim_time=svc.sim_time, robot=robot, detections=d["detections"], image=d["image"])
        return image_result(d["png"], meta)

    @tool(read_only=True, title="Segment the camera image")
    async def segment_camera_image(ctx: Context, robot: str) -> Annotated[CallToolResult, Segmentation]:
        """Instance segmentation of the robot's camera view: a colour per model/link and the pixel share of
        each."""
        svc = app_of(ctx).service
        d = await run(ctx, svc.segment_image, robot)
        meta = Segmentation(sim_time=svc.sim_time, robot=robot, classes=d["classes"][:50],
                            background_fraction=d["background_fraction"], image=d["image"])
        return image_result(d["png"], meta)

    @tool(read_only=True, title="Lidar–camera fusion overlay")
    async def fuse_lidar_camera(ctx: Context, robot: str) -> Annotated[CallToolResult, Overlay]:
        """Project the latest lidar returns into a camera image rendered now (colour = range)."""
        svc = app_of(ctx).service
        d = await run(ctx, svc.lidar_camera_overlay, robot)
        meta = Overlay(sim_time=svc.sim_time, robot=robot, returns=d["returns"], projected=d["projected"],
                       scan_stamp=d["scan_stamp"], depth_range=d["depth_range"], image=d["image"])
        return image_result(d["png"], meta)

    @tool(read_only=True, title="Process sensor data")
    async def process_sensor_data(ctx: Context, robot: str, operation: Literal["clusters", "voxel_filter",
                                  "outlier_removal", "ground_removal"] = "clusters",
                                  eps: float = Field(0.15, gt=0, le=5, description="clusters: neighbour distance"),
                                  min_points: int = Field(3, ge=1, le=1000),
                                  voxel: float = Field(0.1, gt=0, le=10), k: int = Field(8, ge=1, le=100),
                                  std_ratio: float = Field(2.0, gt=0, le=100)) -> Result:
        """Lidar processing in the map frame (obstacle clusters, voxel filter, statistical outlier removal) or
        RANSAC ground removal on a depth-camera cloud."""
        svc = app_of(ctx).service
        out = await run(ctx, svc.process_scan, robot, operation, eps=eps, min_points=min_points, voxel=voxel, k=k,
                        std_ratio=std_ratio)
        return Result(sim_time=svc.sim_time, result=out)

    @tool(read_only=True, title="Sensor health")
    async def monitor_sensor_health(ctx: Context, robot: str | None = None) -> Result:
        """Per stream (lidar, IMU, odometry): measured vs configured rate, latency, dropouts, noise σ, quality
        0–1 and alerts. Monitoring starts at the first call; rates need ~2 s of sim time."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.sensor_health, robot))

    @tool(read_only=False, title="Calibrate a sensor")
    async def calibrate_sensor(ctx: Context, robot: str,
                               kind: Literal["imu_bias", "lidar_offset", "camera_intrinsics"] = "imu_bias",
                               window_s: float = Field(2.0, gt=0, le=60, description="sim seconds of readings "
                                                       "(the robot should stand still)")) -> Result:
        """Collect a window of readings and estimate IMU biases, the lidar mounting offset (scan-to-map ICP)
        or the camera intrinsics; the answer compares with the ground truth."""
        svc = app_of(ctx).service
        cal = await run(ctx, svc.start_calibration, robot, kind)
        if kind != "camera_intrinsics":
            await advance(ctx, window_s, message=lambda: f"collecting {kind} readings")
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.finish_calibration, cal["id"]))

    @tool(read_only=False, title="Start odometry + IMU fusion")
    async def start_sensor_fusion(ctx: Context, robot: str, config: EkfConfig | None = Field(
                                  None, description="EKF noise settings; omitted: defaults")) -> Result:
        """Fuse wheel odometry and the gyro in an EKF from now on; sensor_fusion_status compares it with
        ground truth and raw odometry."""
        svc = app_of(ctx).service
        cfg = config.model_dump(exclude_unset=True) if config is not None else None
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.start_fusion, robot, cfg))

    @tool(read_only=True, title="Sensor fusion status")
    async def sensor_fusion_status(ctx: Context, robot: str) -> Result:
        """The EKF pose, its error against ground truth, and raw odometry's error."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.fusion_status, robot))

    @tool(read_only=False, idempotent=True, title="Stop sensor fusion")
    async def stop_sensor_fusion(ctx: Context, robot: str) -> Result:
        """Stop the EKF; returns its last state."""
        svc = app_of(ctx).service
        return Result(sim_time=svc.sim_time, result=await run(ctx, svc.stop_fusion, robot))
