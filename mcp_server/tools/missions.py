"""Mission and grading tools: validate and run a mission file (in its own world, as fast as possible, in the
background: the id comes back at once), its status and report; grade a course world or robot file."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import anyio
from mcp.server.mcpserver import Context
from pydantic import Field

from mcp_server.app import app_of
from mcp_server.jobs import await_job, job_ref, jobs_of
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat


class MissionJob(Answer):
    job: dict[str, Any]


class MissionCheck(Answer):
    path: str
    valid: bool
    mission: dict[str, Any] | None = None


class Rubric(Answer):
    report: dict[str, Any]


def _report_view(report: dict[str, Any], fmt: ResponseFormat) -> dict[str, Any]:
    if fmt == "full":
        return report
    keep = {k: v for k, v in report.items() if not isinstance(v, dict | list) or k in ("assertions",)}
    keep["assertions"] = [{k: a.get(k) for k in ("name", "passed", "measured", "expected", "message") if k in a}
                          for a in report.get("assertions", [])]
    if fmt == "summary":
        keep["assertions"] = [f"{'PASS' if a['passed'] else 'FAIL'} {a['name']}" for a in keep["assertions"]]
    return keep


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="Validate a mission file")
    async def validate_mission(ctx: Context, path: str = Field(
            description="a shipped mission name or a mission YAML in the workspace")) -> MissionCheck:
        """Check a mission file against the schema (errors name the file, line and field)."""
        from fleet.missions import load_mission

        svc = app_of(ctx).service
        src = svc.workspace.named("missions", path, "mission")
        m = await anyio.to_thread.run_sync(load_mission, src)
        return MissionCheck(sim_time=svc.sim_time, path=str(src), valid=True,
                            mission={"name": m.name, "world": m.world, "seed": m.seed, "time_limit": m.time_limit,
                                     "robots": len(m.robots), "fleets": len(m.fleets), "tasks": len(m.tasks),
                                     "assertions": len(m.assertions)})

    @tool(read_only=False, title="Run a mission")
    async def run_mission(ctx: Context, path: str = Field(description="a shipped mission name (configs/missions) "
                          "or a mission YAML in the workspace"),
                          seed: int | None = None, time_limit: float | None = Field(None, gt=0, le=36_000),
                          record: bool = Field(True, description="write recording.mcap next to the report")) \
            -> MissionJob:
        """Run a mission file headless in its own world (not the live one), as fast as possible, in the
        background. Returns the job id at once: poll mission_status, then mission_report."""
        from fleet.missions.batch import RunRequest, run_file

        app = app_of(ctx)
        svc = app.service
        src = svc.workspace.named("missions", path, "mission")
        out = svc.workspace.resolve(f"runs/{src.stem}", write=True)
        runner = jobs_of(app)
        req = RunRequest(str(src), seed, str(out / f"run{len(runner.jobs) + 1}"), record, time_limit)
        job = runner.start("mission", str(src), lambda progress: run_file(req, progress))
        return MissionJob(sim_time=svc.sim_time, job=job_ref(job))

    @tool(read_only=True, title="Mission status")
    async def mission_status(ctx: Context, job_id: str, wait_s: float = Field(0.0, ge=0, le=600, description=
                             "wait up to this many wall seconds for it to finish (progress notifications)")) \
            -> MissionJob:
        """running (with sim time reached / time limit) or finished with PASS/FAIL and where it wrote."""
        job = await await_job(ctx, job_id, wait_s)
        d: dict[str, Any] = {**job_ref(job), "error": job.error,
                             "progress": {"sim_time": job.progress.get("done"), "time_limit": job.progress.get("total"),
                                          "wall_s": job.progress.get("wall_s")}}
        if job.result is not None:
            d.update({"passed": job.result.passed, "summary": job.result.summary(),
                      "out_dir": str(job.result.out_dir), "error": job.result.error or job.error})
        return MissionJob(sim_time=app_of(ctx).service.snapshot.time, job=d)

    @tool(read_only=True, title="Mission report")
    async def mission_report(ctx: Context, job_id: str, response_format: ResponseFormat = "normal") -> MissionJob:
        """The finished mission's report: verdict, assertions (measured vs expected), metrics, outputs."""
        from sim.errors import ErrorCode, FleetError

        app = app_of(ctx)
        job = jobs_of(app).get(job_id)
        if job.result is None:
            raise FleetError(ErrorCode.BUSY if job.state == "running" else ErrorCode.NOT_FOUND,
                             f"job {job_id} has no report ({job.state}{': ' + job.error if job.error else ''})",
                             "poll mission_status until it has finished")
        return MissionJob(sim_time=app.service.sim_time,
                          job={"id": job.id, "passed": job.result.passed, "out_dir": str(job.result.out_dir),
                               "report": _report_view(job.result.report, response_format)})

    @tool(read_only=True, title="Grade a course world or robot")
    async def grade_course_file(ctx: Context, kind: Literal["world", "robot"],
                                path: str = Field(description="SDF world or URDF robot inside the workspace")) \
            -> Rubric:
        """Check a student's world (SDF) or robot (URDF) against the course rubric: points per item, measured
        vs expected."""
        from fleet.grading import check_robot, check_world

        svc = app_of(ctx).service
        src = svc.workspace.resolve(path)
        check = check_world if kind == "world" else check_robot
        rep = await anyio.to_thread.run_sync(check, Path(src))
        return Rubric(sim_time=svc.sim_time, report=rep.to_dict())
