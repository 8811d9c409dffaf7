"""Robots from URDF cost what YAML robots cost: load + spawn time, and the sim_throughput kinematic row.

The same robot three ways: `configs/robots/diffbot.yaml` (the spec), `diffbot.urdf` (generated from it by
sim.urdf) and `course_robot.urdf` (written by hand from the course assignment; same dimensions, sensors and
limits). Measured in one run:

  load     load_robot_model(file): YAML parse + validation, vs URDF parse + drive/sensor extraction + the
           loadable URDF written (first load, then the mean of repeated loads)
  spawn    World.spawn_robot + remove_robot, kinematic (compound proxy) and dynamic (PyBullet loadURDF)
  row      benchmarks/sim_throughput.py's kinematic no-lidar row (same scene, driver and timing code,
           _sim_runs.run_config), with the URDF-loaded course robot in place of the YAML one; target: within
           10 % of the YAML row's robot-steps/s

Run: .venv/bin/python benchmarks/robot_load.py [--robots 100 1000] [--repeat 20] [--rounds 3]. Results: docs/robot.md.
"""

from __future__ import annotations

import argparse
import functools
import statistics
import time
from collections.abc import Callable

import _sim_runs  # the helpers next to this script (its directory is on sys.path)
from _sim_runs import Budget, Config, run_config
from _sim_scene import make_scene
from rich.console import Console
from rich.table import Table

from sim import Pose2D, RobotSpec, World
from sim.resources import shipped
from sim.robot_load import load_robot_model

SOURCES = {"yaml": shipped("robots", "diffbot.yaml"), "urdf (generated)": shipped("robots", "diffbot.urdf"),
           "urdf (course, by hand)": shipped("robots", "course_robot.urdf")}


def _ms(fn: Callable[[], object], repeat: int) -> tuple[float, float]:
    """(first call, median of the next `repeat`) in ms."""
    t = time.perf_counter()
    fn()
    first = (time.perf_counter() - t) * 1e3
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1e3)
    return first, statistics.median(times)


def _spawn_ms(spec: RobotSpec, fidelity: str, repeat: int) -> float:
    world = World(physics_hz=100)
    try:
        times = []
        for _ in range(repeat + 1):
            t = time.perf_counter()
            world.spawn_robot("r", Pose2D(0.0, 0.0, 0.0), spec=spec, fidelity=fidelity)  # type: ignore[arg-type]
            times.append((time.perf_counter() - t) * 1e3)
            world.remove_robot("r")
        return statistics.median(times[1:])  # the first spawn pays one-off costs (shape caches)
    finally:
        world.close()


def _row(spec: RobotSpec, robots: int) -> tuple[float, float]:
    """(robot-steps per wall second, per CPU second of this process) of the kinematic no-lidar row with `spec`
    as every robot. CPU time is the robust figure on a machine shared with other jobs."""
    base = spec

    def robot_spec(beams: int | None) -> RobotSpec:
        lidar = base.sensors.lidar.model_copy(update={"enabled": beams is not None, "beams": beams or 360})
        return base.model_copy(update={"sensors": base.sensors.model_copy(update={"lidar": lidar})})

    saved = _sim_runs.robot_spec
    _sim_runs.robot_spec = robot_spec  # the row's one robot-specific input; everything else is sim_throughput's
    try:
        r = run_config(Config("kinematic", robots, None, 10.0), make_scene(robots), Budget(50, 2000, 6.0))
    finally:
        _sim_runs.robot_spec = saved
    return r.steps * robots / r.wall_s, r.steps * robots / r.cpu_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=3, help="throughput rows per side (best counts)")
    args = ap.parse_args()
    console = Console()
    specs = {}
    t = Table(title="load + spawn (ms; load: first / median of repeats, spawn: median)")
    for col in ("model", "load first", "load", "spawn kinematic", "spawn dynamic", "warnings"):
        t.add_column(col)
    for label, path in SOURCES.items():
        first, med = _ms(functools.partial(load_robot_model, path), args.repeat)
        loaded = load_robot_model(path)
        specs[label] = loaded.spec
        t.add_row(label, f"{first:.2f}", f"{med:.2f}", f"{_spawn_ms(loaded.spec, 'kinematic', args.repeat):.2f}",
                  f"{_spawn_ms(loaded.spec, 'dynamic', args.repeat):.2f}", str(len(loaded.warnings)))
    console.print(t)
    rows = Table(title="sim_throughput kinematic no-lidar row @10 Hz: robot-steps/s (wall | CPU)")
    for col in ("robots", "yaml", "urdf (course)", "urdf / yaml wall", "urdf / yaml CPU", "target (CPU)"):
        rows.add_column(col)
    for n in args.robots:
        # Interleaved (yaml, urdf, yaml, urdf ...), best of `--rounds` each, so a burst of load on the shared
        # machine hits both sides alike.
        best = {"yaml": (0.0, 0.0), "urdf": (0.0, 0.0)}
        for _ in range(args.rounds):
            for side, spec in (("yaml", specs["yaml"]), ("urdf", specs["urdf (course, by hand)"])):
                wall, cpu = _row(spec, n)
                best[side] = (max(best[side][0], wall), max(best[side][1], cpu))
        (yw, yc), (uw, uc) = best["yaml"], best["urdf"]
        rows.add_row(str(n), f"{yw:,.0f} | {yc:,.0f}", f"{uw:,.0f} | {uc:,.0f}", f"{uw / yw:.3f}", f"{uc / yc:.3f}",
                     "met" if uc / yc >= 0.9 else "MISSED (≥ 0.90)")
    console.print(rows)


if __name__ == "__main__":
    main()
