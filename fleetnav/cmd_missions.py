"""`fleetnav run | validate | replay | diff`: batch missions from the command line.

Heavy imports live inside each command so `fleetnav --help` stays instant. Exit codes: 0 all good,
1 an assertion failed (or runs differ), 2 bad input (a mission file that does not validate, a missing file,
an executor that is not installed), 130 canceled with Ctrl-C (the finished runs are summarized).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from fleetnav.sweep_options import EXECUTOR, RAY_ADDRESS, RETRIES

EXIT_FAILED, EXIT_INPUT, EXIT_CANCELED = 1, 2, 130


def mission_file(name_or_path: str) -> Path:
    """A mission YAML path, or the name of a shipped mission (configs/missions/<name>.yaml)."""
    from sim.errors import ErrorCode, FleetError
    from sim.resources import shipped

    p = Path(name_or_path)
    if p.is_file():
        return p
    cand = shipped("missions", f"{name_or_path}.yaml")
    if p.suffix not in (".yaml", ".yml") and cand.is_file():
        return cand
    known = sorted(f.stem for f in shipped("missions").glob("*.yaml"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no mission file '{name_or_path}'",
                     f"give a mission YAML file, or a shipped mission: {', '.join(known)}")


def run(
    files: list[str] = typer.Argument(..., help="mission YAML files, or names of shipped missions "
                                      "(e.g. arena_navigation)"),
    jobs: int | None = typer.Option(None, "-j", "--jobs", min=1, max=64,
                                    help="local: parallel worker processes (default 1); ray: CPUs of a Ray "
                                         "instance started here (default all)"),
    seed: int | None = typer.Option(None, "--seed", help="override the missions' seed"),
    repeat: int = typer.Option(1, "--repeat", min=1, max=1000, help="run K seeds (seed, seed+1, ...) per mission"),
    out: Path = typer.Option(Path("runs"), "--out", help="output folder (one sub-folder per run)"),
    live: bool = typer.Option(False, "--live", help="Foxglove WebSocket live view; paces the run at real time"),
    port: int = typer.Option(8765, "--port", help="live view port"),
    speed: float = typer.Option(1.0, "--speed", min=0.01, help="with --live: real-time factor to hold"),
    no_record: bool = typer.Option(False, "--no-record", help="skip the MCAP recording"),
    time_limit: float | None = typer.Option(None, "--time-limit", min=0.1, help="override the missions' time limit"),
    executor: str = EXECUTOR,
    ray_address: str | None = RAY_ADDRESS,
    retries: int = RETRIES,
    run_timeout: float = typer.Option(900.0, "--run-timeout", min=1.0, help="wall-clock limit of one run on "
                                      "its worker, s (a hung agent is stopped there)"),
) -> None:
    """Run missions headless, faster than real time; exit 0 only if every assertion holds."""
    from fleet.missions.batch import RunRequest, plan_runs, run_batch, run_file, summarize, write_batch_outputs
    from sim.errors import FleetError

    try:
        paths = [str(mission_file(f)) for f in files]
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(EXIT_INPUT) from None
    reqs = plan_runs(paths, out, seed, repeat, record=not no_record, time_limit=time_limit)
    if live:
        if len(reqs) != 1:
            raise typer.BadParameter("--live shows one run: give one file without --repeat", param_hint="--live")
        from fleet.live_view import LiveView

        view = LiveView(port=port)
        typer.echo(f"live view on ws://127.0.0.1:{port} (in Foxglove: open connection; layout: "
                   "configs/foxglove_layout.json)")
        r = reqs[0]
        outcomes = [run_file(RunRequest(r.path, r.seed, r.out_dir, True, r.time_limit), live=view, pace=speed)]
    else:
        try:
            outcomes = run_batch(reqs, jobs=jobs, executor=executor, ray_address=ray_address, retries=retries,
                                 run_timeout=run_timeout)
        except FleetError as exc:
            typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
            raise typer.Exit(EXIT_INPUT) from exc
    write_batch_outputs(outcomes, out)
    for o in outcomes:
        typer.echo(f"{o.summary()}  → {o.out_dir}")
        for a in o.report.get("assertions", []):
            if not a["passed"]:
                typer.echo(f"    FAILED {a['name']}: {a['message']}")
    if repeat > 1:
        for name, s in summarize(outcomes).items():
            typer.echo(f"{name}: pass rate {s['pass_rate']:.0%} over {s['runs']} seeds")
    if len(outcomes) < len(reqs):  # Ctrl-C: the summary above covers the runs that finished
        typer.echo(f"canceled: {len(reqs) - len(outcomes)} of {len(reqs)} runs did not finish", err=True)
        raise typer.Exit(EXIT_CANCELED)
    if any(a["name"] == "load" for o in outcomes for a in o.report["assertions"]):
        raise typer.Exit(EXIT_INPUT)
    raise typer.Exit(0 if all(o.passed for o in outcomes) else EXIT_FAILED)


def validate(files: list[Path] = typer.Argument(..., help="mission YAML files")) -> None:
    """Check mission files; errors name the file, line and field."""
    from fleet.missions import validate_files

    bad = 0
    for path, err in validate_files(files):
        if err is None:
            typer.echo(f"ok    {path}")
        else:
            bad += 1
            typer.echo(f"error {err}", err=True)
    raise typer.Exit(EXIT_INPUT if bad else 0)


def replay(
    recording: Path = typer.Argument(..., help="a run's recording.mcap"),
    tolerance: float = typer.Option(1e-3, help="largest position divergence accepted, m"),
    as_json: bool = typer.Option(False, "--json", help="print the result as JSON"),
) -> None:
    """Re-drive a fresh world with a recording's commands; report how far it strays from the recorded poses."""
    from fleet.recording import replay as do_replay
    from sim.errors import FleetError

    try:
        r = do_replay(recording)
    except FleetError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc
    if as_json:
        typer.echo(json.dumps(r.to_dict(), indent=2))
    else:
        typer.echo(f"replayed {r.ticks} ticks ({r.end_time:.1f} s sim) of {', '.join(r.robots)}")
        for name, d in r.max_divergence_m.items():
            typer.echo(f"  {name}: max divergence {d:.2e} m, final {r.final_divergence_m.get(name, 0.0):.2e} m")
    raise typer.Exit(0 if r.max_m <= tolerance else EXIT_FAILED)


def diff(
    a: Path = typer.Argument(..., help="run folder, report.json or recording.mcap"),
    b: Path = typer.Argument(..., help="run folder, report.json or recording.mcap"),
    tolerance: float = typer.Option(1e-9, help="numbers closer than this are equal"),
) -> None:
    """Compare two runs: assertion verdicts, metrics, trajectories. Exit 0 if they agree."""
    from fleet.recording import diff_runs
    from sim.errors import FleetError

    try:
        d = diff_runs(a, b, tol=tolerance)
    except FleetError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INPUT) from exc
    for v in d.verdicts:
        typer.echo(f"assertion {v['name']}: {v['a']} → {v['b']} (measured {v['measured_a']} → {v['measured_b']})")
    for m in d.metrics[:50]:
        typer.echo(f"{m['key']}: {m['a']} → {m['b']}")
    if len(d.metrics) > 50:
        typer.echo(f"... and {len(d.metrics) - 50} more")
    for side, keys in d.only_in.items():
        if keys:
            typer.echo(f"only in {side}: {', '.join(keys[:20])}")
    for robot, gap in d.trajectories.items():
        typer.echo(f"trajectory {robot}: max difference {gap:.3g} m")
    typer.echo("identical" if d.identical else "runs differ")
    raise typer.Exit(0 if d.identical else EXIT_FAILED)


def register(app: typer.Typer) -> None:
    for fn in (run, validate, replay, diff):
        app.command()(fn)
