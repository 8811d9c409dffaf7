"""Sensor tools: list sensors, read lidar/IMU/odometry/contact, camera and depth images, joint states, frames
and transforms."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from mcp.server.mcpserver import Context
from mcp_types import CallToolResult
from pydantic import Field

from mcp_server.app import app_of, run
from mcp_server.imaging import camera_png, depth_stats, image_result
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat, r3, scan_payload
from sim.types import ContactReading, ImuReading, LidarScan, OdometryReading, Pose2D


class SensorList(Answer):
    sensors: list[dict[str, Any]]


class SensorReading(Answer):
    robot: str
    sensor: str
    stamp: float
    data: dict[str, Any]


class CameraFrame(Answer):
    robot: str
    which: str
    stamp: float
    width: int
    height: int
    fov_deg: float
    intrinsics: dict[str, float] = Field(description="fx, fy, cx, cy in pixels (renderer convention)")
    camera_pose: dict[str, float] = Field(description="camera link in the map frame (x forward, z up)")
    depth: dict[str, float | None] | None = Field(None, description="depth image: range statistics, m")


class Joints(Answer):
    robot: str
    joints: list[dict[str, Any]]


class Transform(Answer):
    parent: str
    child: str
    translation: list[float]
    rpy: list[float]
    quaternion: list[float] = Field(description="x, y, z, w")


class Frames(Answer):
    frames: list[str]


def reading_data(reading: Any, fmt: ResponseFormat) -> dict[str, Any]:
    """A sensor reading as plain numbers; scans summarised (sector minima) unless fmt=full."""
    if isinstance(reading, LidarScan):
        return scan_payload(reading, fmt)
    if isinstance(reading, ImuReading):
        return {"linear_acceleration": [r3(v) for v in reading.linear_acceleration],
                "angular_velocity": [r3(v) for v in reading.angular_velocity],
                "orientation": [r3(v) for v in reading.orientation]}
    if isinstance(reading, OdometryReading):
        return {"pose": {"x": r3(reading.pose.x), "y": r3(reading.pose.y), "yaw": r3(reading.pose.yaw)},
                "linear": r3(reading.linear), "angular": r3(reading.angular), "frame": f"{reading.robot}/odom",
                **({"wheels": [r3(reading.left_wheel), r3(reading.right_wheel)]} if fmt == "full" else {})}
    if isinstance(reading, ContactReading):
        contacts = [{"other": c.other, "normal_force": r3(c.normal_force),
                     **({"position": [r3(v) for v in c.position]} if fmt != "summary" else {})}
                    for c in reading.contacts]
        return {"bumped": reading.bumped, "contacts": contacts[:50]}
    if isinstance(reading, Pose2D):
        return {"x": r3(reading.x), "y": r3(reading.y), "yaw": r3(reading.yaw), "note": "ground truth"}
    raise TypeError(f"unexpected reading {type(reading).__name__}")


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="List sensors")
    async def list_sensors(ctx: Context, robot: str | None = None,
                           sensor_type: Literal["lidar", "camera", "depth", "imu", "odom", "contact"] | None = None
                           ) -> SensorList:
        """Every robot's sensors (or one robot's, or one type): frame, rate, key figures, latest stamp."""
        svc = app_of(ctx).service
        return SensorList(sim_time=svc.sim_time, sensors=await run(ctx, svc.list_sensors, robot, sensor_type))

    @tool(read_only=True, title="Read a sensor")
    async def read_sensor(ctx: Context, robot: str,
                          sensor: Literal["lidar", "imu", "odom", "contact", "pose"] = "lidar",
                          response_format: ResponseFormat = "summary") -> SensorReading:
        """The latest reading. lidar: beam count, nearest return and the minimum per 45° sector (full: every
        range); imu; odom (wheel odometry, odom frame); contact; pose (ground truth). Camera and depth images:
        get_camera_image."""
        svc = app_of(ctx).service
        reading = await run(ctx, svc.read_sensor, robot, sensor)
        stamp = getattr(reading, "stamp", svc.sim_time)
        return SensorReading(sim_time=svc.sim_time, robot=robot, sensor=sensor, stamp=stamp,
                             data=reading_data(reading, response_format))

    @tool(read_only=True, title="Camera or depth image")
    async def get_camera_image(ctx: Context, robot: str, which: Literal["rgb", "depth"] = "rgb") \
            -> Annotated[CallToolResult, CameraFrame]:
        """Render the robot's RGB camera (640×480) or depth camera now: a PNG image plus intrinsics, camera pose
        and (depth) range statistics."""
        svc = app_of(ctx).service
        sensor = "camera" if which == "rgb" else "depth"
        img = await run(ctx, svc.read_sensor, robot, sensor)
        fx, fy, cx, cy = img.intrinsics
        cp = img.camera_pose
        meta = CameraFrame(sim_time=svc.sim_time, robot=robot, which=which, stamp=img.stamp, width=img.width,
                           height=img.height, fov_deg=img.fov_deg, intrinsics={"fx": fx, "fy": fy, "cx": cx, "cy": cy},
                           camera_pose={"x": r3(cp.x), "y": r3(cp.y), "z": r3(cp.z), "yaw": r3(cp.yaw)},
                           depth=depth_stats(img) if which == "depth" else None)
        return image_result(camera_png(img, which), meta)

    @tool(read_only=True, title="Joint states")
    async def get_joint_states(ctx: Context, robot: str) -> Joints:
        """Wheel joint angles (rad) and rates (rad/s)."""
        svc = app_of(ctx).service
        js = await run(ctx, svc.joint_states, robot)
        joints = [{k: (r3(v) if isinstance(v, float) else v) for k, v in j.items()} for j in js["joints"]]
        return Joints(sim_time=js["stamp"], robot=robot, joints=joints)

    @tool(read_only=True, title="Transform between frames")
    async def get_transform(ctx: Context, parent: str = Field("map", description="e.g. map, r1/odom, r1/base_link"),
                            child: str = Field(description="e.g. r1/lidar, r1/camera, a model name")) -> Transform:
        """The pose of `child` in `parent` now (REP-105 tree: map → <robot>/odom → <robot>/base_link → sensors)."""
        svc = app_of(ctx).service
        t = await run(ctx, svc.transform, parent, child)
        return Transform(sim_time=t["stamp"], parent=parent, child=child, translation=t["translation"],
                         rpy=t["rpy"], quaternion=t["quaternion"])

    @tool(read_only=True, title="List frames")
    async def list_frames(ctx: Context, robot: str | None = None) -> Frames:
        """Frame names for get_transform (one robot's, or all robots' and every model's)."""
        svc = app_of(ctx).service
        return Frames(sim_time=svc.sim_time, frames=await run(ctx, svc.frames, robot))
