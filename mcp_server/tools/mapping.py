"""SLAM and localisation tools: start/stop SLAM on a robot, status with ATE against ground truth, the map as an
image, save/load maps in the workspace, localise in a known map and its quality."""

from __future__ import annotations

import io
from typing import Annotated, Any, Literal

from mcp.server.mcpserver import Context
from mcp_types import CallToolResult
from pydantic import Field

from fleet.validation import map_resolution
from mcp_server.app import app_of, run
from mcp_server.imaging import image_result
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import OVERWRITE, Answer, ResponseFormat
from planning import render_map
from planning.grid import OccupancyGrid
from sim import Pose2D
from slam.log_config import LogSlamConfig
from slam.types import SlamConfig


class Slam(Answer):
    slam: dict[str, Any]


class MapFile(Answer):
    map: dict[str, Any]


class MapList(Answer):
    maps: list[dict[str, Any]]


class Localisation(Answer):
    localization: dict[str, Any]


class LogSlamResult(Answer):
    result: dict[str, Any] = Field(description="report.json: scans, loop closures (accepted/rejected, reasons), "
                                   "ms/scan, real-time factor, ATE/RPE vs the log's reference poses if any, out")


class GridImage(Answer):
    source: str
    width: int
    height: int
    resolution: float
    origin: list[float] = Field(description="map position of the lower-left corner of the image, m")
    metres_per_pixel: float
    orientation: str = "north up: +x right, +y up"


def grid_png(grid: OccupancyGrid, max_px: int) -> tuple[bytes, float]:
    scale = max(1, min(4, max_px // max(grid.width, grid.height)))
    img = render_map(grid, scale=scale)
    mpp = grid.resolution / scale
    if max(img.size) > max_px:
        f = max_px / max(img.size)
        img = img.resize((max(1, round(img.width * f)), max(1, round(img.height * f))))
        mpp /= f
    buf = io.BytesIO()
    img.save(buf, format="PNG", optimize=True)
    return buf.getvalue(), mpp


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=False, title="Start SLAM")
    async def start_slam(ctx: Context, robot: str, config: SlamConfig | None = Field(None, description=
                         "slam.SlamConfig sections: odometry, keyframes, loop_closure, pose_graph, mapping")) -> Slam:
        """Run online SLAM (KISS-ICP odometry, GTSAM pose graph with loop closures, occupancy mapping) on the
        robot's lidar from now on; drive the robot around, then read slam_status / get_slam_map."""
        svc = app_of(ctx).service
        cfg = config.model_dump(exclude_unset=True) if config is not None else None
        map_resolution(cfg)
        return Slam(sim_time=svc.sim_time, slam=await run(ctx, svc.start_slam, robot, cfg))

    @tool(read_only=False, idempotent=True, title="Stop SLAM")
    async def stop_slam(ctx: Context, robot: str) -> Slam:
        """Stop feeding scans; the map and trajectory stay available."""
        svc = app_of(ctx).service
        return Slam(sim_time=svc.sim_time, slam=await run(ctx, svc.stop_slam, robot))

    @tool(read_only=True, title="SLAM status")
    async def slam_status(ctx: Context, robot: str, response_format: ResponseFormat = "normal") -> Slam:
        """Scans, keyframes, estimated vs true pose, ATE/RPE against ground truth, loop closures (accepted and
        rejected, with reasons), map size."""
        svc = app_of(ctx).service
        d = await run(ctx, svc.slam_status, robot)
        if response_format == "summary":
            d = {k: d[k] for k in ("robot", "running", "scans", "keyframes", "pose", "pose_error_m",
                                   "loop_closures_accepted", "ate")}
        return Slam(sim_time=svc.sim_time, slam=d)

    @tool(read_only=True, title="SLAM map image")
    async def get_slam_map(ctx: Context, robot: str | None = Field(None, description="a robot running SLAM"),
                           map_name: str | None = Field(None, description="or a loaded map"),
                           max_px: int = Field(800, ge=64, le=4096)) -> Annotated[CallToolResult, GridImage]:
        """The robot's SLAM map (or a loaded map) as a PNG: black occupied, white free, grey unknown."""
        from sim.errors import ErrorCode, FleetError

        if (robot is None) == (map_name is None):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "give exactly one of robot or map_name",
                             "list_maps shows loaded maps")
        svc = app_of(ctx).service
        grid = await run(ctx, svc.slam_map, robot) if robot else await run(ctx, svc.map_grid, map_name)
        png, mpp = grid_png(grid, max_px)
        meta = GridImage(sim_time=svc.sim_time, source=f"slam of {robot}" if robot else f"map {map_name}",
                         width=grid.width, height=grid.height, resolution=grid.resolution,
                         origin=[round(grid.origin[0], 4), round(grid.origin[1], 4)], metres_per_pixel=round(mpp, 5))
        return image_result(png, meta)

    @tool(read_only=False, title="Run SLAM on a recorded log")
    async def run_slam_on_log(
        ctx: Context,
        path: str = Field(description="CARMEN .log / .log.gz or .mcap recording (LaserScan) inside the workspace"),
        out: str | None = Field(None, description="output folder in the outputs area (default: slam/<log name>): "
                                "map.pgm/yaml/png, trajectory.tum, trajectory_odom.tum, graph.g2o, report.json"),
        odometry: Literal["odom_increments", "laser_pose", "none"] = Field(
            "odom_increments", description="CARMEN odometry: raw ODOM increments (honest default), the laser "
            "lines' poses (corrected reference poses in Radish logs: not an honest input), or none"),
        config: LogSlamConfig | None = Field(None, description="SLAM settings (frontend, loops, mapping, "
                                             "max_range, point_spacing, laser); odometry is its own argument"),
        max_px: int = Field(800, ge=64, le=4096, description="longest side of the returned map image, px"),
    ) -> Annotated[CallToolResult, LogSlamResult]:
        """Map a recorded log (correlative + ICP scan-to-map front end, branch-and-bound loop closure, GTSAM
        with a robust kernel); returns the report (ATE/RPE against the log's reference poses when it has them)
        and the map image with the trajectory (red) and odometry (blue)."""
        import anyio
        from PIL import Image

        svc = app_of(ctx).service
        report = await anyio.to_thread.run_sync(lambda: svc.run_slam_on_log(
            path, out, odometry, config.model_dump(exclude_unset=True, exclude={"odometry"}) if config else None))
        img = Image.open(f"{report['out']}/map.png")
        img.thumbnail((max_px, max_px))
        buf = io.BytesIO()
        img.save(buf, format="PNG", optimize=True)
        return image_result(buf.getvalue(), LogSlamResult(sim_time=svc.snapshot.time, result=report))

    @tool(read_only=False, title="Save the SLAM map")
    async def save_slam_map(ctx: Context, robot: str, path: str = Field(description="a .yaml path inside the "
                            "outputs area; the PGM goes next to it"), overwrite: bool = OVERWRITE) -> MapFile:
        """Write the robot's map as ROS map_server PGM + YAML; it is also loaded under the file's stem."""
        svc = app_of(ctx).service
        if overwrite:
            svc.workspace.permit_overwrite(path)
        return MapFile(sim_time=svc.sim_time, map=await run(ctx, svc.save_slam_map, robot, path))

    @tool(read_only=False, title="Load a map")
    async def load_slam_map(ctx: Context, path: str = Field(description="map_server .yaml inside the workspace"),
                            name: str | None = None) -> MapFile:
        """Load a map_server map for localisation (and get_slam_map)."""
        svc = app_of(ctx).service
        return MapFile(sim_time=svc.sim_time, map=await run(ctx, svc.load_slam_map, path, name))

    @tool(read_only=True, title="List maps")
    async def list_maps(ctx: Context) -> MapList:
        """Maps loaded (or saved) in this session, with size and resolution."""
        svc = app_of(ctx).service
        return MapList(sim_time=svc.sim_time, maps=await run(ctx, svc.list_maps))

    @tool(read_only=False, title="Localise a robot in a map")
    async def localize_robot(ctx: Context, robot: str, map_name: str,
                             x: float | None = Field(None, description="initial guess; omit x, y, yaw for global "
                                                     "localisation"), y: float | None = None, yaw: float = 0.0,
                             sigma_xy: float = Field(0.25, gt=0, le=50), sigma_yaw: float = Field(0.2, gt=0, le=7)
                             ) -> Localisation:
        """Start AMCL-like particle-filter localisation (refined by scan-to-map ICP) in a loaded map; it
        updates on every scan. Read localization_status for the estimate and its quality."""
        from sim.errors import ErrorCode, FleetError

        if (x is None) != (y is None):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "give both x and y, or neither (global localisation)")
        svc = app_of(ctx).service
        init = Pose2D(x, y, yaw) if x is not None and y is not None else None
        out = await run(ctx, svc.localize, robot, map_name, init, sigma_xy=sigma_xy, sigma_yaw=sigma_yaw)
        return Localisation(sim_time=svc.sim_time, localization=out)

    @tool(read_only=True, title="Localisation status and quality")
    async def localization_status(ctx: Context, robot: str) -> Localisation:
        """Estimate, quality (particle spread, match score, ambiguity, converged) and error vs ground truth."""
        svc = app_of(ctx).service
        return Localisation(sim_time=svc.sim_time, localization=await run(ctx, svc.localization_status, robot))

    @tool(read_only=False, idempotent=True, title="Stop localisation")
    async def stop_localization(ctx: Context, robot: str) -> Localisation:
        """Stop localising the robot; returns the last estimate."""
        svc = app_of(ctx).service
        return Localisation(sim_time=svc.sim_time, localization=await run(ctx, svc.stop_localization, robot))
