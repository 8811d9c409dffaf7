"""Recording tools: start/stop an MCAP recording of the live service (Foxglove schemas), list recordings in the
workspace, replay one (its recorded commands re-driven in a fresh world, divergence reported)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import anyio
import yaml
from mcp.server.mcpserver import Context
from pydantic import Field

from mcp_server.app import app_of, run
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import OVERWRITE, Answer
from sim.errors import ErrorCode, FleetError


class Recording(Answer):
    recording: dict[str, Any]


class Recordings(Answer):
    recordings: list[dict[str, Any]]


def session_mission(svc: Any) -> str:
    """The service as it is now, written as a mission (world, physics, robots) so the recording carries what a
    replay needs to rebuild the world."""
    c = svc.config
    robots = [{"name": n, "pose": {"x": p.x, "y": p.y, "yaw": p.yaw}, "model": svc.registry.get(n).model,
               "fidelity": svc.world.robot_fidelity(n)}
              for n, p in ((n, svc.world.robot_pose(n)) for n in svc.world.robot_names())]
    doc = {"name": "mcp_session", "description": "recorded from the MCP server", "world": str(svc.world_path),
           "seed": c.seed, "time_limit": 36_000, "end_when": "time_limit",
           "physics": {"physics_hz": c.physics_hz, "control_hz": c.control_hz, "fidelity": c.fidelity},
           "robots": robots, "assertions": [{"type": "no_collisions"}]}
    return yaml.safe_dump(doc, sort_keys=False)


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=False, title="Start recording")
    async def start_recording(ctx: Context, path: str = Field(description="an .mcap path inside the workspace"),
                              scans: bool = True, camera_robot: str | None = Field(None, description="also record "
                              "this robot's camera at 1 Hz"), overwrite: bool = OVERWRITE) -> Recording:
        """Record the fleet (poses, TF, scans, map, markers, events, state) to MCAP from now on; open it in
        Foxglove. One recording at a time. Robots must exist before recording for a replay to rebuild them."""
        from fleet.recording import McapRecorder

        app = app_of(ctx)
        svc = app.service
        if overwrite:
            svc.workspace.permit_overwrite(path)
        if "recording" in app.extras:
            raise FleetError(ErrorCode.BUSY, f"already recording to {app.extras['recording'][1]}",
                             "call stop_recording first")
        target = svc.workspace.resolve(path, write=True)
        if target.suffix != ".mcap":
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a recording path ends in .mcap, got '{path}'")
        rec = McapRecorder(target, scans=scans, camera_robot=camera_robot)
        await run(ctx, lambda: rec.attach(svc, session_mission(svc), svc.config.seed))
        app.extras["recording"] = (rec, target, svc.sim_time)
        return Recording(sim_time=svc.sim_time, recording={"path": str(target), "started": svc.sim_time})

    @tool(read_only=False, title="Stop recording")
    async def stop_recording(ctx: Context) -> Recording:
        """Finish the recording; returns the message count per topic."""
        app = app_of(ctx)
        if "recording" not in app.extras:
            raise FleetError(ErrorCode.NOT_FOUND, "no recording is running", "call start_recording first")
        rec, target, started = app.extras.pop("recording")
        counts = await run(ctx, rec.close)
        t = app.service.sim_time
        return Recording(sim_time=t, recording={"path": str(target), "started": started, "duration_s": t - started,
                                                "messages": counts, "bytes": target.stat().st_size})

    @tool(read_only=True, title="List recordings")
    async def list_recordings(ctx: Context, directory: str = Field(".", description="inside the workspace")) \
            -> Recordings:
        """MCAP files under a workspace directory with their topics and message counts."""
        from fleet.recording import channel_counts

        svc = app_of(ctx).service
        root = svc.workspace.resolve(directory)
        if not root.is_dir():
            raise FleetError(ErrorCode.NOT_FOUND, f"no directory '{directory}' in the workspace")

        def scan() -> list[dict[str, Any]]:
            out = []
            for p in sorted(root.rglob("*.mcap"))[:100]:
                try:
                    topics = {t: n for t, (_, n) in channel_counts(p).items()}
                except FleetError as exc:
                    topics = {"error": exc.message}  # type: ignore[dict-item]
                out.append({"path": str(Path(p).relative_to(svc.workspace.root)) if svc.workspace.root in p.parents
                            else str(p), "bytes": p.stat().st_size, "topics": topics})
            return out

        return Recordings(sim_time=svc.sim_time, recordings=await anyio.to_thread.run_sync(scan))

    @tool(read_only=True, title="Replay a recording")
    async def replay_recording(ctx: Context, path: str = Field(description="an .mcap inside the workspace")) \
            -> Recording:
        """Rebuild the recorded world in a fresh simulation (not the live one), re-drive the recorded commands
        and report how far each robot diverged from its recorded poses."""
        from fleet.recording import replay

        svc = app_of(ctx).service
        src = svc.workspace.resolve(path)
        result = await anyio.to_thread.run_sync(replay, src)
        return Recording(sim_time=svc.sim_time, recording=result.to_dict())
