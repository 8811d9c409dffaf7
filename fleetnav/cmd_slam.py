"""`fleetnav slam run LOG --out DIR` (SLAM on a recorded CARMEN or MCAP log) and `fleetnav slam eval TRAJ REF`.

Exit codes: 0 done, 2 bad input (unreadable log or config, unknown field).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer

slam_app = typer.Typer(no_args_is_help=True, help="SLAM on recorded logs (CARMEN .log/.log.gz, MCAP).")
EXIT_INPUT = 2


@slam_app.command("run")
def run(
    log: Path = typer.Argument(..., help="CARMEN .log / .log.gz, or an .mcap recording"),
    out: Path = typer.Option(..., "--out", help="output folder (created): map, trajectories, graph, report"),
    config: Path | None = typer.Option(None, "--config", help="YAML with LogSlamConfig fields (slam/log_config.py)"),
    odometry: str | None = typer.Option(None, "--odometry", help="override: odom_increments | laser_pose | none"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
) -> None:
    """Map a recorded log; writes map.pgm/yaml/png, trajectory.tum, trajectory_odom.tum, graph.g2o, report.json."""
    from sim.config import dump_yaml, load_yaml
    from sim.errors import FleetError
    from slam.log_config import LogSlamConfig
    from slam.log_run import run_log

    try:
        cfg = load_yaml(config, LogSlamConfig) if config else LogSlamConfig()
        if odometry is not None:
            cfg = LogSlamConfig.model_validate({**cfg.model_dump(), "odometry": odometry})
    except FleetError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc
    except ValueError as exc:  # pydantic: a bad --odometry value
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc

    def progress(done: int, total: int, ms: float) -> None:
        if quiet:
            return
        w = 30
        fill = int(w * done / max(total, 1))
        sys.stderr.write(f"\r[{'#' * fill}{'.' * (w - fill)}] {done}/{total} scans  {ms:6.1f} ms/scan")
        if done == total:
            sys.stderr.write("\n")
        sys.stderr.flush()

    try:
        report = run_log(log, out, cfg, progress)
    except FleetError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc
    dump_yaml(cfg, out / "config.yaml")
    lc = report["loop_closures"]
    typer.echo(f"{report['scans']} scans, {report['ms_per_scan']:.1f} ms/scan, loop closures {lc['accepted']} "
               f"accepted / {lc['rejected']} rejected")
    for key in ("slam", "odometry_only"):
        if key in report:
            m = report[key]
            typer.echo(f"{key:>13}: ATE {m['ate_rmse']:.3f} m, RPE consecutive "
                       f"{m['rpe_consecutive']['trans_mean']:.3f} m / {m['rpe_consecutive']['rot_mean_deg']:.2f}°")
    ref = report.get("reference")
    if ref and ref["kind"] in ("raw_odometry", "unknown"):  # the laser-line poses are not (known to be) a reference
        typer.echo(f"laser-line poses: {ref['note']}")
    typer.echo(f"wrote {out}/ (map.pgm, map.yaml, map.png, trajectory.tum, trajectory_odom.tum, graph.g2o, "
               "report.json)")


@slam_app.command("eval")
def eval_cmd(
    traj: Path = typer.Argument(..., help="estimated trajectory, TUM format"),
    ref: Path = typer.Argument(..., help="reference trajectory, TUM format"),
    tolerance: float = typer.Option(0.02, "--tolerance", min=0.0, help="stamp association tolerance, s"),
) -> None:
    """ATE (after SE(2) alignment) and RPE (consecutive, 1 m, 10 m) of TRAJ against REF, as JSON."""
    from sim.errors import FleetError
    from slam.log_eval import evaluate_files

    try:
        result = evaluate_files(traj, ref, tolerance)
    except FleetError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc
    typer.echo(json.dumps(result, indent=1))
