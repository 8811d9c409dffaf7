"""Simulation throughput: real-time factor and robot-steps/s of sim.World next to raw PyBullet and the peer.

For 1, 10, 100, 500 and 1000 robots, in each drive model, with and without lidar, on one scene (robots on a
3 m grid with obstacles between them, see _sim_scene.py) driven by random arcs (_sim_driver.py):

  ours       driver commands + World.step(), timed per step
  raw        PyBullet doing the same step's work right after ours, on a twin client built from the same SDF
             (_raw_pybullet.py): kinematic = reset every robot to our new pose + performCollisionDetection +
             getContactPoints (detection only); dynamic = velocity motors on both wheels + stepSimulation;
             lidar = rayTestBatch of all beams
  peer       pybullet-fleet 0.8.0 on the same scene in /tmp/pbf (_pbf_workload.py), largest kinematic fleet,
             run right after our row for it

Targets (issue 2): kinematic 1000 robots at 10 Hz ≥ 10× real time with collisions resolved; dynamic per-step
cost ≤ 1.25 × raw. Issue 17: lidar through Embree (the World's default ray caster) ≥ 10× the rays/s of raw
rayTestBatch (whole step counted); 100 robots × 360 beams at 10 Hz ≥ 5× real time; 1000 robots × 90 beams ≥ 1×.
`--raycast` adds the ray casters alone on the same recorded lidar rays (_raycast_bench.py), alternating.

Run: .venv/bin/python benchmarks/sim_throughput.py [--quick] [--json out.json] [--peer-robot box|urdf]
     [--no-peer | --peer-only] [--raycaster embree|pybullet] [--raycast [--raycast-only]] [--no-lidar].
Results and what each side does: docs/benchmarks-sim.md.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import _sim_runs
from _peer import PeerResult, run_peer  # the _helpers next to this script (its directory is on sys.path)
from _raycast_bench import CastResult, compare
from _sim_runs import WARMUP_STEPS, Budget, Config, Result, run_config
from _sim_scene import make_scene, robot_spec
from rich.console import Console
from rich.table import Table

KINEMATIC_HZ = 10.0  # the peer's setting and the target's
DYNAMIC_HZ = 100.0  # the World's default: wheeled contact physics needs small steps
RTF_TARGET = 10.0
RATIO_TARGET = 0.8  # dynamic: 1 / 1.25 of raw speed
LIDAR_RATIO_TARGET = 10.0  # issue 17: Embree lidar rays/s (whole step) vs raw rayTestBatch
LIDAR_RTF_TARGETS = {(100, 360): 5.0, (1000, 90): 1.0}  # issue 17: (robots, beams) → real-time factor
KINEMATIC_COST_TARGET = 1.2  # issue 17: kinematic 1000 robots, no sensors: our step ≤ 1.2 × raw detect-only


def configs(counts: list[int]) -> list[Config]:
    out = []
    for n in counts:
        out += [Config("kinematic", n, None, KINEMATIC_HZ), Config("kinematic", n, 360, KINEMATIC_HZ)]
        if n >= 100:
            out.append(Config("kinematic", n, 90, KINEMATIC_HZ))  # the low-resolution lidar for big fleets
    for n in counts:
        out += [Config("dynamic", n, None, DYNAMIC_HZ), Config("dynamic", n, 360, DYNAMIC_HZ)]
    return out


def target(r: Result) -> tuple[str, bool | None]:
    """The target this row is held to (text) and whether it is met by wall-clock time (None: no target)."""
    c = r.config
    if c.drive == "kinematic" and c.beams is None and c.robots == 1000:
        return (f"RTF ≥ {RTF_TARGET:g}, no overlap, cost ≤ {KINEMATIC_COST_TARGET:g}× raw",
                r.rtf >= RTF_TARGET and r.overlaps_end == 0 == r.raw_overlap_steps
                and r.step_s <= KINEMATIC_COST_TARGET * r.raw_step_s)
    if c.drive == "kinematic" and c.beams is not None and c.robots >= 100:
        rtf = LIDAR_RTF_TARGETS.get((c.robots, c.beams))
        text = f"rays/s ≥ {LIDAR_RATIO_TARGET:g}× raw" + (f", RTF ≥ {rtf:g}" if rtf else "")
        return text, ratio(r) >= LIDAR_RATIO_TARGET and (rtf is None or r.rtf >= rtf)
    if c.drive == "dynamic" and c.beams is None:
        return "cost ≤ 1.25× raw", ratio(r) >= RATIO_TARGET
    return "—", None


def ratio(r: Result) -> float:
    """Our speed over raw PyBullet's for the same work (1 = the engine's limit)."""
    if r.config.beams is not None and r.config.drive == "kinematic":
        return r.rays_per_s / r.raw_rays_per_s
    return r.raw_step_s / r.step_s


def cost(r: Result) -> str:
    """Our step's cost over raw's for the same work, wall (CPU time): the issue-17 kinematic figure."""
    if r.config.beams is not None:
        return ""
    cpu = f" ({r.cpu_s / r.steps / r.raw_motion_cpu_s:.2f})" if r.raw_motion_cpu_s > 0 else ""
    return f"{r.step_s / r.raw_step_s:.2f}{cpu}"


def checks(r: Result) -> str:
    text = f"moved {100 * r.moved:.0f}%, {r.blocked:.1f} blocked/step"
    if r.config.drive == "kinematic":
        text += f", overlaps {r.overlaps_end} end / {r.raw_overlap_steps} of {r.steps} steps"
    return text


def table(results: list[Result], peer: PeerResult | str | None) -> Table:
    t = Table(title="sim.World throughput vs raw PyBullet (same process, same scene)")
    for col in ("config", "robots", "our RTF", "RTF cpu", "robot-steps/s", "ms/step", "raw ms/step", "Mrays/s",
                "raw Mrays/s", "ours/raw", "cost ÷ raw (cpu)", "peer RTF (cpu)", "target", "met", "checks"):
        t.add_column(col, justify="left" if col in ("config", "target", "checks") else "right")
    peer_row = max((r for r in results if r.config.drive == "kinematic" and r.config.beams is None),
                   key=lambda r: r.config.robots)
    for r in results:
        text, met = target(r)
        lidar = r.config.beams is not None
        peer_txt = ""
        if r is peer_row and peer is not None:
            peer_txt = f"{peer.rtf:.2f} ({peer.rtf_cpu:.2f})" if isinstance(peer, PeerResult) else "unavailable"
        met_txt = {None: "", True: "yes", False: "NO"}[met]
        if met is False and r.config.beams is None and r.config.drive == "kinematic" and r.rtf_cpu >= RTF_TARGET \
                and r.overlaps_end == 0 == r.raw_overlap_steps \
                and r.cpu_s / r.steps <= KINEMATIC_COST_TARGET * r.raw_motion_cpu_s:
            met_txt = "NO (cpu: yes)"
        t.add_row(r.config.label, str(r.config.robots), f"{r.rtf:.2f}", f"{r.rtf_cpu:.2f}",
                  f"{r.robot_steps_per_s:,.0f}",
                  f"{1e3 * r.step_s:.2f}", f"{1e3 * r.raw_step_s:.2f}",
                  f"{r.rays_per_s / 1e6:.2f}" if lidar else "", f"{r.raw_rays_per_s / 1e6:.2f}" if lidar else "",
                  f"{ratio(r):.2f}", cost(r), peer_txt, text, met_txt, checks(r))
    return t


def peer_run(args: argparse.Namespace, n: int, steps: int, console: Console) -> PeerResult | str:
    try:
        with tempfile.TemporaryDirectory(prefix="fleetnav_peer_") as tmp:
            urdf = Path(tmp) / "diffbot.urdf"
            if args.peer_robot == "urdf":
                from sim.urdf import robot_urdf

                urdf.write_text(robot_urdf(robot_spec(None)), encoding="utf-8")
            peer = run_peer(make_scene(n), robot_spec(None), steps, WARMUP_STEPS, args.peer_robot, str(urdf))
    except RuntimeError as exc:
        console.print(f"  [bold red]peer pybullet-fleet could not run: {exc}[/]")
        return f"unavailable: {exc}"
    console.print(f"  peer pybullet-fleet {peer.version} ({args.peer_robot} robots) {n:5d} robots: RTF {peer.rtf:8.2f} "
                  f"(cpu {peer.rtf_cpu:8.2f}), moved {100 * peer.moved:.0f}%, {peer.collisions_started} collisions "
                  f"detected, none resolved (load {os.getloadavg()[0]:.2f})")
    return peer


def raycast_section(args: argparse.Namespace, console: Console) -> list[CastResult]:
    # (robots, beams, movable models): with movable models the engine steps and every body is posed from PyBullet
    pairs = [(100, 360, 0), (1000, 90, 0)] if args.quick else [(100, 360, 0), (300, 360, 0), (1000, 90, 0),
                                                               (1000, 360, 0), (100, 360, 20)]
    out = []
    for n, beams, movable in pairs:
        out.append(compare(n, beams, 3.0 if args.quick else 10.0, movable))
        r = out[-1]
        console.print(f"  ray casters {n:5d} robots × {beams} beams + {movable} movable: "
                      f"embree {r.rays / r.embree_s / 1e6:.2f} Mrays/s, "
                      f"rayTestBatch {r.rays / r.pybullet_s / 1e6:.2f} Mrays/s, {r.ratio:.1f}× wall, "
                      f"{r.cpu_ratio:.1f}× CPU time; bare rays, no layout (before 17c) {r.pybullet_s / r.bare_s:.1f}× "
                      f"({r.pybullet_cpu_s / r.bare_cpu_s:.1f}× CPU); robots rebuilt per cast (before 17a) "
                      f"{r.pybullet_s / r.rebuild_s:.1f}× (load {os.getloadavg()[0]:.2f})")
    t = Table(title="ray casters on the same lidar rays (one sweep of every robot, alternating backends)")
    for col in ("robots × beams", "rays", "embree ms/cast", "rayTestBatch ms/cast", "embree Mrays/s",
                "rayTestBatch Mrays/s", "ratio", "CPU ms/cast embree / rTB", "CPU ratio",
                "bare rays ms/cast (ratio, CPU ratio)", "rebuild ms/cast (ratio, CPU ratio)", "target", "met",
                "hit/miss agree", "range diff median / p99 mm", "layout vs bare: same uid, max mm"):
        t.add_column(col, justify="right")
    for r in out:
        label = f"{r.robots} × {r.beams}" + (f" + {r.movable} movable" if r.movable else "")
        t.add_row(label, f"{r.rays:,}", f"{1e3 * r.embree_s:.1f}", f"{1e3 * r.pybullet_s:.1f}",
                  f"{r.rays / r.embree_s / 1e6:.2f}", f"{r.rays / r.pybullet_s / 1e6:.2f}", f"{r.ratio:.1f}×",
                  f"{1e3 * r.embree_cpu_s:.1f} / {1e3 * r.pybullet_cpu_s:.1f}", f"{r.cpu_ratio:.1f}×",
                  *(f"{1e3 * w:.1f} ({r.pybullet_s / w:.1f}×, {r.pybullet_cpu_s / c:.1f}×)"
                    for w, c in ((r.bare_s, r.bare_cpu_s), (r.rebuild_s, r.rebuild_cpu_s))),
                  f"≥ {LIDAR_RATIO_TARGET:g}×", "yes" if r.ratio >= LIDAR_RATIO_TARGET else "NO",
                  f"{100 * r.hit_agree:.2f}%", f"{r.median_mm:.4f} / {r.p99_mm:.2f}",
                  f"{100 * r.layout_agree:.2f}%, {r.layout_max_mm:.1e}")
    console.print(t)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="1, 10, 100 robots, short runs (a few seconds each)")
    ap.add_argument("--json", type=Path, help="also write every figure to this JSON file")
    ap.add_argument("--peer-robot", choices=("box", "urdf"), default="box",
                    help="peer robot body: our footprint box (default) or our full robot URDF")
    ap.add_argument("--no-peer", action="store_true", help="skip pybullet-fleet")
    ap.add_argument("--peer-only", action="store_true", help="run only pybullet-fleet (e.g. with --peer-robot urdf)")
    ap.add_argument("--robots", type=int, nargs="+", help="fleet sizes to run (default 1 10 100 500 1000)")
    ap.add_argument("--drive", choices=("kinematic", "dynamic"), help="run only this drive model")
    ap.add_argument("--no-lidar", action="store_true", help="only the rows without lidar (e.g. the kinematic target)")
    ap.add_argument("--raycaster", choices=("embree", "pybullet"), default="embree",
                    help="the World's ray caster for the lidar rows (default embree)")
    ap.add_argument("--raycast", action="store_true", help="also compare the ray casters alone on the same rays")
    ap.add_argument("--raycast-only", action="store_true", help="only the ray-caster comparison")
    args = ap.parse_args()
    _sim_runs.RAYCASTER = args.raycaster
    counts = args.robots or ([1, 10, 100] if args.quick else [1, 10, 100, 500, 1000])
    budget = Budget(5, 100, 0.5) if args.quick else Budget(10, 300, 3.0)
    peer_steps = 100 if args.quick else 600  # the peer-comparison row runs exactly as many 0.1 s steps
    console = Console(width=220)
    console.print(f"python {platform.python_version()}, {os.cpu_count()} cpus, load {os.getloadavg()}, "
                  f"{time.strftime('%Y-%m-%d %H:%M:%S')}")
    results: list[Result] = []
    peer: PeerResult | str | None = None
    casts = raycast_section(args, console) if args.raycast or args.raycast_only else []
    if args.raycast_only:
        if args.json:
            args.json.write_text(json.dumps({"raycast": [asdict(c) for c in casts], "load": os.getloadavg()},
                                            indent=1), encoding="utf-8")
        return
    if args.peer_only:
        peer = peer_run(args, counts[-1], peer_steps, console)
    for cfg in [] if args.peer_only else [c for c in configs(counts) if args.drive in (None, c.drive)
                                          and not (args.no_lidar and c.beams is not None)]:
        headline = cfg.drive == "kinematic" and cfg.beams is None and cfg.robots == counts[-1]
        b = Budget(peer_steps, peer_steps, 0.0) if headline else budget
        results.append(run_config(cfg, make_scene(cfg.robots), b))
        r = results[-1]
        console.print(f"  {cfg.label:28s} {cfg.robots:5d} robots: RTF {r.rtf:8.2f} (cpu {r.rtf_cpu:8.2f}), ours "
                      f"{1e3 * r.step_s:7.2f} ms/step, raw {1e3 * r.raw_step_s:7.2f}, CPU ms/step ours "
                      f"{1e3 * r.cpu_s / r.steps:.2f} raw {1e3 * r.raw_motion_cpu_s:.2f} ({r.steps} steps, setup "
                      f"{r.setup_s:.1f} s, load {os.getloadavg()[0]:.2f})")
        if headline and not args.no_peer:  # right after ours, so both see about the same machine load
            peer = peer_run(args, cfg.robots, peer_steps, console)
    if results:
        console.print(table(results, peer))
    console.print(f"load after: {os.getloadavg()}")
    if args.json:
        rows = [{**asdict(r), "rtf": r.rtf, "rtf_cpu": r.rtf_cpu, "robot_steps_per_s": r.robot_steps_per_s,
                 "ratio": ratio(r), "target": target(r)[0], "met": target(r)[1]} for r in results]
        args.json.write_text(json.dumps({"results": rows, "raycast": [asdict(c) for c in casts],
                                         "peer": asdict(peer) if isinstance(peer, PeerResult)
                                         else peer, "load": os.getloadavg()}, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
