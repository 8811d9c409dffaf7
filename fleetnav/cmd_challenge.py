"""`fleetnav challenge run|leaderboard|arenas|list`: navigation challenges graded with the BARN metric.

Exit codes of `run`: 0 every run reached the goal, 1 some run failed (the report says why), 2 bad input.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from fleetnav.sweep_options import EXECUTOR, RAY_ADDRESS, RETRIES

challenge_app = typer.Typer(add_completion=False, no_args_is_help=True,
                            help="Navigation challenges: grade an agent or a builtin navigator (BARN score).")


def _fail(exc: Exception) -> typer.Exit:
    from sim.errors import FleetError

    assert isinstance(exc, FleetError)
    typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
    return typer.Exit(2)


@challenge_app.command("run")
def run(challenge: str = typer.Argument(..., help="a name in configs/challenges or a challenge .yaml"),
        agent: str | None = typer.Option(None, help='the contestant\'s command, e.g. "python my_nav.py"'),
        controller: str | None = typer.Option(None, help="builtin:<name>, e.g. builtin:mpc_osqp"),
        runs: int | None = typer.Option(None, min=1, max=100, help="override the challenge's number of runs"),
        out: Path | None = typer.Option(None, help="report directory (default challenge_results/<name>/<who>)"),
        leaderboard: Path | None = typer.Option(None, help="add the result to this leaderboard file"),
        name: str | None = typer.Option(None, help="the contestant's name on the leaderboard"),
        as_json: bool = typer.Option(False, "--json", help="print the report as JSON"),
        executor: str = EXECUTOR,
        jobs: int | None = typer.Option(None, "-j", "--jobs", min=1, max=64,
                                        help="local: runs in parallel processes (default 1: in turn, here); ray: "
                                             "CPUs of a Ray instance started here"),
        ray_address: str | None = RAY_ADDRESS,
        retries: int = RETRIES,
        live: bool = typer.Option(False, "--live", help="Foxglove live view of each run in turn, paced at --speed"),
        port: int = typer.Option(8765, "--port", help="live view port"),
        speed: float = typer.Option(1.0, "--speed", min=0.01, help="with --live: real-time factor to hold"),
        map_source: str | None = typer.Option(
            None, "--map-source", help="override the challenge's rule: sensors (default of the shipped challenges: "
            "the contestant knows only its lidar, an agent is refused the map), prior (a known map), both"))\
        -> None:
    """Grade a contestant: each run ends at the goal, a collision, the time limit, or an agent fault."""
    from fleet.executors import make_executor
    from fleet.grading import RunResult, run_challenge
    from fleet.grading import leaderboard as board
    from fleet.grading.challenge import Challenge, load_challenge
    from fleet.grading.runner import LiveSettings
    from sim.errors import ErrorCode, FleetError

    def progress(r: RunResult) -> None:
        if not as_json:
            typer.echo(f"run {r.run} (seed {r.seed}): {r.outcome.value}, score {r.score.score:.3f} — {r.reason}")

    try:
        ex = None if executor == "local" and (jobs or 1) == 1 and ray_address is None else \
            make_executor(executor, jobs=jobs, ray_address=ray_address, retries=retries)
        chosen: Challenge | str = challenge
        if map_source is not None:
            if map_source not in ("sensors", "prior", "both"):
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"--map-source must be sensors, prior or both, got "
                                 f"'{map_source}'")
            chosen = load_challenge(challenge).model_copy(update={"map_source": map_source})
        report = run_challenge(chosen, agent=agent, controller=controller, runs=runs, out_dir=out,
                               progress=progress, executor=ex, live=LiveSettings(port, speed) if live else None)
        if live:
            typer.echo(f"live view was on ws://127.0.0.1:{port} (layout: configs/foxglove_layout.json)")
        if leaderboard is not None:
            board.add(leaderboard, report, name)
    except FleetError as exc:
        raise _fail(exc) from exc
    if as_json:
        typer.echo(json.dumps(report.to_dict(), indent=2))
    else:
        from fleet.grading.report import markdown

        typer.echo(markdown(report).split("\n![trajectories]")[0])
        typer.echo(f"report: {report.files['html']}")
    raise typer.Exit(0 if report.success_rate == 1.0 else 1)


@challenge_app.command("leaderboard")
def show_leaderboard(file: Path = typer.Argument(..., help="a leaderboard .json written by `challenge run`"),
                     challenge: str | None = typer.Option(None, help="only this challenge")) -> None:
    """Print the leaderboard, ranked by mean score, then success rate, then time."""
    from fleet.grading import leaderboard as board
    from sim.errors import FleetError

    if not file.is_file():
        typer.echo(f"error: no leaderboard file {file}", err=True)
        raise typer.Exit(2)
    try:
        typer.echo(board.markdown(board.load(file), challenge))
    except FleetError as exc:
        raise _fail(exc) from exc


@challenge_app.command("arenas")
def arenas(count: int = typer.Option(5, min=1, max=40, help="arenas in the graded set"),
           per_level: int = typer.Option(8, min=1, max=50, help="candidates per obstacle-density level"),
           size: float = typer.Option(10.0, min=4.0, max=60.0, help="arena side, m"),
           out: Path | None = typer.Option(None, help="write challenge files here (default: print only)")) -> None:
    """Generate cluttered arenas, rank them by difficulty, print their metrics (and write challenge files)."""
    from fleet.grading.arenas import candidates, generate, table, write_challenges

    infos = generate(count, candidates(per_level=per_level, size=size))
    typer.echo(table(infos))
    if out is not None:
        for p in write_challenges(infos, out):
            typer.echo(f"wrote {p}")


@challenge_app.command("list")
def list_challenges() -> None:
    """The shipped challenges."""
    from fleet.grading import load_challenge
    from fleet.grading.challenge import CHALLENGES

    for path in sorted(CHALLENGES.glob("*.yaml")):
        ch = load_challenge(path)
        typer.echo(f"{ch.name:16s} {ch.description}")
