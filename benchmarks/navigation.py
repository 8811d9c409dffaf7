"""Navigation end to end in the sim, and the tracking controllers on a figure-eight.

Part 1 — navigator (plan → track → replan → recover) in sim.World, kinematic fidelity by default, on
configs/worlds/robot_arena.world and sim.worldgen.cluttered_arena(seed=7, difficulty 1, 3, 5). Per map, N random
start/goal pairs (both free, ≥ 2 m apart, connected: "where a path exists"). Baseline, measured in the same
run on the same pair: the optimal any-angle grid path (Theta* on a fresh costmap), length L_opt, and
T_opt = L_opt / v_max. Reported per map: success rate, planning time (median, p95 over every plan the
navigator made), length ratios (first plan and driven distance over L_opt), time to goal, collisions
(the sim's contact check, every control tick), minimum footprint clearance (fcl on the world's true shapes)
and the BARN metric success × T_opt / clip(T, 2·T_opt, 8·T_opt) (mean).

Part 2 — each controller tracks a figure-eight (lemniscate, 4 m × 2 m, 12.2 m) at 0.5 m/s in an empty
kinematic world at 20 Hz: solve time per step (median, p99) and RMS cross-track error; regulated pure
pursuit is the baseline.

    .venv/bin/python benchmarks/navigation.py            # 100 pairs per map
    .venv/bin/python benchmarks/navigation.py --quick    # 10 pairs per map
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from planning import FclWorld, LayeredCostmap, get_planner
from planning.controllers import PathReference, make_controller
from planning.global_planners.common import cell_of, check_reachable
from planning.nav_types import NavState
from planning.navigator import NavigatorConfig, make_navigator
from sim import Pose2D, World
from sim.errors import FleetError
from sim.sdf_parser import parse_sdf
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription
from sim.worldgen import cluttered_arena

ROOT = Path(__file__).resolve().parent.parent
CONTROL_HZ = 20.0


def maps() -> list[WorldDescription]:
    return [parse_sdf(ROOT / "configs/worlds/robot_arena.world"),
            *(cluttered_arena(seed=7, difficulty=d) for d in (1, 3, 5))]


def sample_pair(cm: LayeredCostmap, rng: np.random.Generator) -> tuple[Pose2D, Pose2D]:
    xmin, ymin, xmax, ymax = cm.bounds
    while True:
        s, g = (Pose2D(float(rng.uniform(xmin, xmax)), float(rng.uniform(ymin, ymax)),
                       float(rng.uniform(-math.pi, math.pi))) for _ in range(2))
        if not (cm.is_free(s.x, s.y) and cm.is_free(g.x, g.y)) or s.distance_to(g) < 2.0:
            continue
        try:
            check_reachable(cm, cell_of(cm, s.x, s.y), cell_of(cm, g.x, g.y))
        except FleetError:
            continue  # no path exists: not counted
        return s, g


def navigate_once(world: World, nav_cfg: NavigatorConfig, base: LayeredCostmap, fcl_world: FclWorld,
                  start: Pose2D, goal: Pose2D, l_opt: float) -> dict[str, Any]:
    spec = world.robot_spec("r1")
    world.set_robot_pose("r1", start)
    world.run_for(0.2)  # at rest until a fresh scan of the new place exists
    nav = make_navigator(nav_cfg, costmap=base.copy(), spec=spec)
    t_opt = l_opt / spec.limits.max_linear
    nav.set_goal(goal, world.time)
    steps = round(world.physics_hz / CONTROL_HZ)
    collided, clearance, driven = False, math.inf, 0.0
    prev = world.robot_pose("r1")
    while not nav.state.done:  # bounded: the navigator fails itself after cfg.timeout_s
        pose = world.robot_pose("r1")
        world.set_cmd_vel("r1", *nav.tick(world.time, pose, world.robot_twist("r1"), world.latest_scan("r1")))
        world.step(steps)
        now = world.robot_pose("r1")
        driven += now.distance_to(prev)
        prev = now
        collided |= world.robot_in_collision("r1")
        clearance = min(clearance, fcl_world.min_distance(now, spec.footprint))
    st = nav.status()
    ok = st.state is NavState.SUCCEEDED
    return {"ok": ok, "reason": st.reason, "T": st.elapsed_s, "t_opt": t_opt,
            "barn": (t_opt / min(max(st.elapsed_s, 2 * t_opt), 8 * t_opt)) if ok else 0.0,
            "plan_times": [p.planning_time_s for p in nav.plans],
            "plan_ratio": nav.plans[0].length / l_opt if nav.plans else math.nan,
            "driven_ratio": driven / l_opt, "collided": collided, "clearance": clearance,
            "replans": st.replans, "recoveries": st.recoveries}


def bench_map(desc: WorldDescription, runs: int, fidelity: str, controller: str, planner: dict[str, Any],
              seed: int) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{desc.name}.world"
        save_sdf(desc, path)
        world = World.from_sdf(path, fidelity=fidelity, seed=seed)
    spec = world.default_spec()
    base = LayeredCostmap.from_world(desc, robot_radius=spec.footprint_radius)
    theta = get_planner("theta_star")
    fcl_world = FclWorld(desc)
    cfg = NavigatorConfig(planner=planner, controller={"type": controller}, timeout_s=None)
    s0, _ = sample_pair(base, rng)
    world.spawn_robot("r1", s0)
    rows: list[dict[str, Any]] = []
    wall0 = time.perf_counter()
    while len(rows) < runs:
        start, goal = sample_pair(base, rng)
        try:
            l_opt = theta.plan(start, goal, base).length
        except FleetError:
            continue
        cfg.timeout_s = 8 * l_opt / spec.limits.max_linear + 30.0
        try:
            rows.append(navigate_once(world, cfg, base, fcl_world, start, goal, l_opt))
        except FleetError as exc:  # the teleport refused a pose the costmap thought free: resample
            if exc.code.value != "COLLISION":
                raise
    world.close()
    return summarise(desc.name, rows, time.perf_counter() - wall0)


def summarise(name: str, rows: list[dict[str, Any]], wall: float) -> dict[str, Any]:
    ok = [r for r in rows if r["ok"]]
    pt = np.array([t for r in rows for t in r["plan_times"]]) * 1e3
    fails = sorted({r["reason"][:70] for r in rows if not r["ok"]})
    return {"map": name, "runs": len(rows), "success": 100.0 * len(ok) / len(rows),
            "plan_med": float(np.median(pt)), "plan_p95": float(np.percentile(pt, 95)),
            "plan_ratio": float(np.nanmedian([r["plan_ratio"] for r in rows])),
            "driven_ratio": float(np.median([r["driven_ratio"] for r in ok])) if ok else math.nan,
            "t_goal": float(np.median([r["T"] for r in ok])) if ok else math.nan,
            "t_opt": float(np.median([r["t_opt"] for r in rows])),
            "collisions": sum(r["collided"] for r in rows),
            "clearance": float(min(r["clearance"] for r in rows)),
            "barn": float(np.mean([r["barn"] for r in rows])),
            "replans": sum(r["replans"] for r in rows), "recoveries": sum(r["recoveries"] for r in rows),
            "wall_s": wall, "fails": fails}


# ---- part 2: controllers on a figure-eight ------------------------------------------------------------------


def figure_eight() -> PathReference:
    s = np.linspace(0.0, 2 * math.pi, 4000)
    xy = np.column_stack([2.0 * np.sin(s), 2.0 * np.sin(s) * np.cos(s)])
    return PathReference.from_points(xy, max_v=0.5, max_a=1.0, max_lat_a=10.0)


def track_figure_eight(cfg: dict[str, Any], fidelity: str) -> dict[str, Any]:
    ref = figure_eight()
    with World(fidelity=fidelity, seed=1) as world:  # type: ignore[arg-type]
        yaw0 = float(ref.yaw[0])
        world.spawn_robot("r1", Pose2D(0.0, 0.0, yaw0))
        ctrl = make_controller(cfg, world.robot_spec("r1").limits)
        steps = round(world.physics_hz / CONTROL_HZ)
        times, steps_t, errs, converged = [], [], [], 0
        while world.time < 60.0:
            pose = world.robot_pose("r1")
            t0 = time.perf_counter()
            out = ctrl.compute(pose, world.robot_twist("r1"), ref, now=world.time)
            steps_t.append(time.perf_counter() - t0)
            times.append(out.solve_time_s)
            errs.append(out.cross_track)
            converged += out.converged
            world.set_cmd_vel("r1", out.v, out.w)
            world.step(steps)
            if ref.remaining(out.progress) < 0.02 and abs(world.robot_twist("r1")[0]) < 1e-3:
                break
        e, t, st = np.array(errs), np.array(times) * 1e3, np.array(steps_t) * 1e3
        return {"name": cfg["type"] + (f"/{cfg['solver']}" if "solver" in cfg else ""), "steps": len(t),
                "med": float(np.median(t)), "p99": float(np.percentile(t, 99)),
                "step_med": float(np.median(st)), "step_p99": float(np.percentile(st, 99)),
                "rms": 100 * math.sqrt(float(np.mean(e**2))), "max": 100 * float(np.abs(e).max()),
                "converged": 100.0 * converged / len(t), "lap_s": world.time}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="10 pairs per map")
    ap.add_argument("--runs", type=int, default=None, help="pairs per map (default 100, 10 with --quick)")
    ap.add_argument("--fidelity", choices=["kinematic", "dynamic"], default="kinematic")
    ap.add_argument("--controller", default="mpc_osqp", help="navigator controller type")
    ap.add_argument("--planner", default="theta_star", help="navigator global planner type")
    ap.add_argument("--planner-budget", type=float, default=None, help="time_budget_s for OMPL planners")
    ap.add_argument("--skip-maps", action="store_true", help="only the controller figure-eight part")
    ap.add_argument("--skip-controllers", action="store_true", help="only the navigator part")
    args = ap.parse_args()
    runs = args.runs or (10 if args.quick else 100)

    if not args.skip_controllers:
        print(f"## Controllers: figure-eight at 0.5 m/s, {args.fidelity} sim, {CONTROL_HZ:.0f} Hz control "
              "(baseline: regulated pure pursuit)")
        print(f"{'controller':24s} {'steps':>6s} {'solve med ms':>13s} {'p99 ms':>8s} {'step med ms':>12s} "
              f"{'p99 ms':>7s} {'RMS xtrack cm':>14s} {'max cm':>7s} {'converged %':>12s} {'lap s':>6s}")
        for cfg in ({"type": "pure_pursuit"}, {"type": "mpc_osqp"}, {"type": "mpc_casadi", "solver": "sqpmethod"},
                    {"type": "mpc_casadi", "solver": "ipopt"}):
            r = track_figure_eight(cfg, args.fidelity)
            print(f"{r['name']:24s} {r['steps']:6d} {r['med']:13.3f} {r['p99']:8.3f} {r['step_med']:12.3f} "
                  f"{r['step_p99']:7.3f} {r['rms']:14.2f} "
                  f"{r['max']:7.2f} {r['converged']:12.1f} {r['lap_s']:6.1f}", flush=True)
    if args.skip_maps:
        return
    planner: dict[str, Any] = {"type": args.planner}
    if args.planner_budget is not None:
        planner["time_budget_s"] = args.planner_budget
    print(f"\n## Navigator ({args.controller}, {args.planner}, reactive layer on), {args.fidelity} sim, "
          f"{runs} start/goal pairs per map (baseline: Theta* optimal any-angle path on the same pair)")
    print(f"{'map':28s} {'success %':>9s} {'plan med ms':>11s} {'p95 ms':>7s} {'plan/opt':>8s} {'driven/opt':>10s} "
          f"{'T s':>6s} {'T_opt s':>7s} {'coll':>5s} {'min clr m':>9s} {'BARN':>6s} {'replan':>6s} {'recov':>5s} "
          f"{'wall s':>7s}")
    for desc in maps():
        r = bench_map(desc, runs, args.fidelity, args.controller, planner, seed=11)
        print(f"{r['map']:28s} {r['success']:9.1f} {r['plan_med']:11.2f} {r['plan_p95']:7.2f} {r['plan_ratio']:8.3f} "
              f"{r['driven_ratio']:10.3f} {r['t_goal']:6.1f} {r['t_opt']:7.1f} {r['collisions']:5d} "
              f"{r['clearance']:9.3f} {r['barn']:6.3f} {r['replans']:6d} {r['recoveries']:5d} {r['wall_s']:7.1f}",
              flush=True)
        for f in r["fails"]:
            print(f"    failure: {f}")


if __name__ == "__main__":
    main()
