"""Navigation challenge tools: list the shipped challenges, grade a built-in controller on one (BARN score, in
its own world, in the background: the id comes back at once), its status and report. External agent commands
are not accepted over MCP: a tool argument must never become a process to run (use `fleetnav challenge`)."""

from __future__ import annotations

from typing import Any

from mcp.server.mcpserver import Context
from pydantic import Field

from mcp_server.app import app_of
from mcp_server.jobs import await_job, job_ref, jobs_of
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer, ResponseFormat
from sim.errors import ErrorCode, FleetError


class Challenges(Answer):
    challenges: list[dict[str, Any]]


class ChallengeJob(Answer):
    job: dict[str, Any]


def _report_view(rep: dict[str, Any], fmt: ResponseFormat) -> dict[str, Any]:
    if fmt == "full":
        return rep
    d = {k: rep[k] for k in ("challenge", "contestant", "summary", "files")}
    d["rubric"] = {k: rep["rubric"][k] for k in ("earned", "total", "passed")}
    if fmt == "normal":
        d["runs"] = [{k: r.get(k) for k in ("run", "outcome", "score", "time_s", "path_length", "reason") if k in r}
                     for r in rep["runs"]]
    return d


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=True, title="List navigation challenges")
    async def list_challenges(ctx: Context) -> Challenges:
        """The shipped challenges (configs/challenges): world or generated arena, start, goal, limits."""
        from fleet.grading import load_challenge
        from fleet.grading.challenge import CHALLENGES

        svc = app_of(ctx).service
        out = []
        for p in sorted(CHALLENGES.glob("*.yaml")):
            ch = load_challenge(p)
            out.append({"name": ch.name, "description": ch.description, "world": ch.world,
                        "arena": ch.arena.model_dump() if ch.arena else None, "time_limit": ch.time_limit,
                        "runs": ch.runs, "success_radius": ch.success_radius})
        return Challenges(sim_time=svc.sim_time, challenges=out)

    @tool(read_only=False, title="Run a navigation challenge")
    async def run_challenge(ctx: Context, challenge: str = Field(description="a shipped challenge name, or a "
                            "challenge YAML inside the workspace"),
                            controller: str = Field("mpc_osqp", description="built-in controller to grade"),
                            runs: int | None = Field(None, ge=1, le=100, description="omitted: the challenge's")) \
            -> ChallengeJob:
        """Grade a built-in navigator on a challenge (BARN-style score per run, rubric, report files). Runs in
        the background in its own world; poll challenge_status, then challenge_report."""
        from fleet.grading import run_challenge as grade
        from planning import controller_names
        from sim.errors import unknown_name

        app = app_of(ctx)
        svc = app.service
        name = controller.removeprefix("builtin:")
        if name not in controller_names():
            raise unknown_name("controller", name, controller_names(), ErrorCode.INVALID_ARGUMENT)
        src = svc.workspace.named("challenges", challenge, "challenge")
        out = svc.workspace.resolve("challenge_results", write=True)
        total = runs or 1

        def work(progress: Any) -> Any:
            done: list[Any] = []

            def on_run(result: Any) -> None:
                done.append(result)
                progress(len(done), total)

            return grade(src, controller=f"builtin:{name}", runs=runs, out_dir=out / f"{src.stem}_{name}",
                         progress=on_run)

        job = jobs_of(app).start("challenge", str(src), work)
        return ChallengeJob(sim_time=svc.sim_time, job=job_ref(job))

    @tool(read_only=True, title="Challenge status")
    async def challenge_status(ctx: Context, job_id: str, wait_s: float = Field(0.0, ge=0, le=600, description=
                               "wait up to this many wall seconds for it to finish (progress notifications)")) \
            -> ChallengeJob:
        """running (runs done so far) or finished with success rate and mean score."""
        job = await await_job(ctx, job_id, wait_s)
        d: dict[str, Any] = {**job_ref(job), "error": job.error,
                             "runs_done": job.progress.get("done"), "wall_s": job.progress.get("wall_s")}
        if job.result is not None:
            d.update({"success_rate": job.result.success_rate, "mean_score": job.result.mean_score})
        return ChallengeJob(sim_time=app_of(ctx).service.snapshot.time, job=d)

    @tool(read_only=True, title="Challenge report")
    async def challenge_report(ctx: Context, job_id: str, response_format: ResponseFormat = "normal") \
            -> ChallengeJob:
        """The finished challenge's report: per-run outcome and score, summary statistics, rubric, files."""
        app = app_of(ctx)
        job = jobs_of(app).get(job_id)
        if job.result is None:
            raise FleetError(ErrorCode.BUSY if job.state == "running" else ErrorCode.NOT_FOUND,
                             f"job {job_id} has no report ({job.state}{': ' + job.error if job.error else ''})",
                             "poll challenge_status until it has finished")
        return ChallengeJob(sim_time=app.service.sim_time,
                            job={"id": job.id, "report": _report_view(job.result.to_dict(), response_format)})
