"""`fleetnav barn run`: the BARN benchmark as a built-in suite (results.jsonl + summary.json, BARN's metric)."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from fleetnav.sweep_options import EXECUTOR, RAY_ADDRESS, RETRIES

barn_app = typer.Typer(add_completion=False, no_args_is_help=True,
                       help="BARN (Benchmark for Autonomous Robot Navigation) worlds as a built-in suite.")


def _ids(text: str | None) -> list[int] | None:
    if not text:
        return None
    try:
        return [int(t) for t in text.replace(" ", "").split(",") if t]
    except ValueError as exc:
        raise typer.BadParameter(f"--ids must be comma-separated integers, got '{text}'") from exc


@barn_app.command("run")
def run(
    worlds_dir: Path = typer.Option(..., "--worlds-dir", help="directory of world_N.world + path_N.npy pairs"),
    ids: str = typer.Option(None, "--ids", help="comma-separated world ids (default: every pair in the directory)"),
    robot: str = typer.Option("barn_jackal", "--robot", help="robot model name (configs/robots) or YAML file"),
    controller: str = typer.Option("builtin:footprint_dwa", "--controller", help="builtin:NAME"),
    agent: str = typer.Option(None, "--agent", help="an agent process drives instead of a builtin, over Zenoh in "
                              "lock-step, e.g. \"python my_nav.py --connect {connect} --robot {robot} --goal "
                              "{goal_x} {goal_y} --lockstep\" (placeholders as `fleetnav challenge run`)"),
    tick_timeout: float = typer.Option(2.0, "--tick-timeout", min=0.01, help="with --agent: wall s per lock-step "
                                       "tick before the agent counts as hung"),
    map_source: str = typer.Option("sensors", "--map-source",
                                   help="sensors (lidar only, BARN rules; an --agent is refused the world's "
                                   "map) | prior (the world file) | both"),
    margin: float = typer.Option(None, "--margin", min=0.0, help="safety margin footprint↔obstacle, m"),
    runs: int = typer.Option(1, "--runs", min=1, help="runs per world"),
    jobs: int | None = typer.Option(None, "-j", "--jobs", min=1, max=64,
                                    help="local: parallel worker processes (default 1); ray: CPUs of a Ray "
                                         "instance started here (default all)"),
    executor: str = EXECUTOR,
    ray_address: str | None = RAY_ADDRESS,
    retries: int = RETRIES,
    out: Path = typer.Option(Path("barn_out"), "--out", help="output directory"),
) -> None:
    """Run BARN worlds from start (−2.25, 3) to goal (−2.25, 13); write OUT/results.jsonl and OUT/summary.json."""
    from fleet.grading.barn_suite import make_jobs, run_suite
    from fleet.paths import robot_file
    from sim.errors import FleetError
    from sim.robot_spec import load_robot_spec

    if agent is not None and not agent.strip():
        typer.echo("error: the agent command is empty (e.g. --agent \"python my_nav.py\")", err=True)
        raise typer.Exit(2)
    if map_source not in ("sensors", "prior", "both"):
        typer.echo(f"error: --map-source must be sensors, prior or both, got '{map_source}'", err=True)
        raise typer.Exit(2)
    nav: dict[str, object] = {"map_source": map_source}
    if margin is not None:
        nav["margin"] = margin
    try:
        spec = load_robot_spec(robot_file(robot))
        todo = make_jobs(worlds_dir, spec=spec, ids=_ids(ids), controller=controller, runs=runs, nav=nav,
                         agent=agent or "", agent_limits={"tick_timeout_s": tick_timeout})
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc

    def show(row: dict[str, object]) -> None:
        typer.echo(f"world {row['world_id']:>3} run {row['run']}: {row['outcome']:<10} T={row['time_s']} s "
                   f"metric={row['barn_metric']} wall={row['wall_s']} s")

    try:
        summary = run_suite(todo, out, workers=jobs, progress=show,
                            executor=executor, ray_address=ray_address, retries=retries)
    except FleetError as exc:  # an executor that is not installed, --ray-address without ray, ...
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc
    typer.echo(json.dumps(summary, indent=2))
    raise typer.Exit(0 if summary["runs"] and "error" not in summary["outcomes"] else 1)
