"""Fleet throughput on warehouse.world: random go-to tasks with ORCA avoidance, and with avoidance off.

N robots (20, 50, 100) spawn at random free spots (rejection sampling, 1.2 m apart) and each gets a new
random go-to goal (free, ≥ 3 m away, ≥ 0.5 m clearance) as soon as its previous task ends, for T sim
minutes. Reported per run: tasks completed per sim-minute, failed tasks, robot-robot collisions (contact
episodes between two robots, from the world's contact check), robot-obstacle collisions, near misses
(footprints closer than 0.3 m, edge-triggered), deadlocks detected / resolved, and the real-time factor
(sim time / wall time of the loop). The baseline, measured in the same run on the same seed and spawn: the
same fleet with `avoidance: {type: none}` (deadlock handling stays on in both).

Settings (kept cheap for big fleets): kinematic fidelity, physics 50 Hz, control 10 Hz, costmap 0.1 m,
guided Theta* planner, regulated pure pursuit at 0.6 m/s, navigator reactive layer on, lidar 90 beams at
5 Hz (diffbot otherwise).

    .venv/bin/python benchmarks/fleet.py                 # 20, 50, 100 robots × 10 sim-minutes, orca and none
    .venv/bin/python benchmarks/fleet.py --quick         # 20 and 50 robots × 1 sim-minute
    .venv/bin/python benchmarks/fleet.py --robots 50 --minutes 2 --avoidance orca
    .venv/bin/python benchmarks/fleet.py --robots 100 --minutes 10 --traffic --avoidance orca --baseline-minutes 2
        # issue 17: the PIBT traffic layer (360-beam lidar at 10 Hz, independent collision check) beside ORCA
    .venv/bin/python benchmarks/fleet.py --robots 100 --minutes 10 --traffic --traffic-lidar on off \
        --avoidance orca --baseline-minutes 2     # the traffic layer with lidar on and off, then ORCA
    .venv/bin/python benchmarks/fleet.py --robots 100 --minutes 3 --traffic-only --traffic-lidar off \
        --priority goal_age since_progress        # the two PIBT priority rules, same run
    .venv/bin/python benchmarks/fleet.py --robots 100 --minutes 10 --traffic-only --traffic-lidar off \
        --rule old new      # without and with the rules against long waits (lanes, aging, yield aside), same run
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fleet import Event, FleetConfig, FleetService
from fleet.traffic.admission import ADMISSION
from fleet.traffic.settings import WITHDRAW
from sim import Pose2D

ROOT = Path(__file__).resolve().parent.parent
NAVIGATION = {"controller": {"type": "pure_pursuit", "desired_linear_vel": 0.6},
              "planner": {"type": "guided_theta_star"}}
LIDAR = {"beams": 90, "rate_hz": 5.0}  # the navigators' reactive layer still sees obstacles; 8x fewer rays
RULES: dict[str, dict[str, Any]] = {  # traffic layer: the rules against long waits, off (old) and on (new: the
    # layer's defaults; urgent_s 10 s since the twelfth landing, l3 and l4 keep the 12 s they were measured with)
    "old": {"urgent_s": None, "yield_aside": False, "highway": 1.0, "lane_cost": 1.0, "push_frozen": False,
            "window": 2},
    "l3": {"urgent_s": 12.0, "yield_aside": True, "highway": 4.0, "lane_cost": 3.0, "push_frozen": False,
           "window": 2},
    "l4": {"urgent_s": 12.0, "yield_aside": True, "highway": 4.0, "lane_cost": 3.0, "push_frozen": True,
           "urgent_rank": "since_urgent"},
    "new": {"urgent_s": 10.0, "yield_aside": True, "highway": 4.0, "lane_cost": 3.0, "push_frozen": True,
            "urgent_rank": "since_progress"},
    "cong": {"urgent_s": 10.0, "yield_aside": True, "highway": 4.0, "lane_cost": 3.0, "push_frozen": True,
             "urgent_rank": "since_progress"}}
LIDAR_FULL = {"beams": 360, "rate_hz": 10.0}  # issue 17's traffic runs: the full lidar on every robot
LIDAR_OFF = {"enabled": False}


def robot_model(tmp: Path, lidar: dict[str, Any] = LIDAR, name: str = "diffbot_bench.yaml") -> str:
    """diffbot with the given lidar, written next to the run (FleetConfig.robot_model takes a path)."""
    import yaml

    spec = yaml.safe_load((ROOT / "configs/robots/diffbot.yaml").read_text())
    spec["sensors"]["lidar"].update(lidar)
    path = tmp / name
    path.write_text(yaml.safe_dump(spec))
    return str(path)


def config(avoidance: str, seed: int, model: str) -> FleetConfig:
    return FleetConfig(world="warehouse", seed=seed, physics_hz=50.0, control_hz=10.0, costmap_resolution=0.1,
                       navigation=NAVIGATION, avoidance={"type": avoidance}, robot_model=model)


class Goals:
    """Random free goals: clearance ≥ 0.5 m from static obstacles, ≥ 3 m from where the robot is."""

    def __init__(self, svc: FleetService, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.bounds = svc.world.description.bounds()
        self.clearance = svc.static_clearance()
        self.radius = svc.default_spec().footprint_radius

    def sample(self, here: Pose2D) -> Pose2D:
        xmin, ymin, xmax, ymax = self.bounds
        while True:
            xy = self.rng.uniform([xmin, ymin], [xmax, ymax], (64, 2))
            ok = (self.clearance.query(xy)[0] > self.radius + 0.5) & (np.hypot(*(xy - [here.x, here.y]).T) >= 3.0)
            if ok.any():
                x, y = xy[np.flatnonzero(ok)[0]]
                return Pose2D(float(x), float(y), float(self.rng.uniform(-math.pi, math.pi)))


def run(n: int, minutes: float, avoidance: str, seed: int, model: str) -> dict[str, Any]:
    svc = FleetService(config(avoidance, seed, model))
    try:
        svc.spawn_fleet(n, "random", spacing=1.2)
        names = set(svc.robot_names())
        goals = Goals(svc, seed + 1)
        contacts: set[tuple[frozenset[str], int]] = set()
        obstacle_hits = 0

        def on_collision(ev: Event) -> None:
            nonlocal obstacle_hits
            robots = [o for o in ev.data.get("others", []) if o in names]
            for o in robots:  # both robots report the same contact: count the pair once per step
                contacts.add((frozenset((ev.robots[0], o)), round(ev.stamp * 1000)))
            if not robots:
                obstacle_hits += 1

        svc.events.subscribe(on_collision, kinds=["collision"])
        done = failed = 0
        reasons: dict[str, int] = {}
        end = minutes * 60.0
        t0, c0 = time.perf_counter(), time.process_time()
        seen = svc.events.last_seq
        while svc.world.time < end - 1e-9:
            for r in svc.robot_names():  # a new goal for every robot that has none
                if r not in svc.tasks.active and not svc.tasks.queues.get(r):
                    svc.navigate(r, goals.sample(svc.robot(r).pose))
            svc.advance(1.0)
            for ev in svc.events.since(seen, kinds=["task_finished", "task_failed"], limit=100_000):
                if ev.kind == "task_finished":
                    done += 1
                else:
                    failed += 1
                    key = str(ev.data.get("reason", ""))[:60]
                    reasons[key] = reasons.get(key, 0) + 1
            seen = svc.events.last_seq
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rep = svc.deadlock_report()
        return {"robots": n, "avoidance": avoidance, "sim_min": minutes, "done_per_min": done / minutes,
                "done": done, "failed": failed, "robot_collisions": len({p for p, _ in _episodes(contacts)}),
                "robot_contacts": len(_episodes(contacts)), "obstacle_hits": obstacle_hits,
                "near_misses": svc.control.stats["near_misses"], "deadlocks": rep["detected"],
                "resolved": rep["resolved"], "unresolved": rep["unresolved"], "rtf": svc.world.time / wall,
                "wall_s": wall, "cpu_s": cpu, "fail_reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1])[:3])}
    finally:
        svc.close()


def _episodes(contacts: set[tuple[frozenset[str], int]]) -> list[tuple[frozenset[str], int]]:
    """Contact events of a pair closer than 1 s apart belong to one episode."""
    out: list[tuple[frozenset[str], int]] = []
    last: dict[frozenset[str], int] = {}
    for pair, ms in sorted(contacts, key=lambda c: c[1]):
        if pair not in last or ms - last[pair] > 1000:
            out.append((pair, ms))
        last[pair] = ms
    return out


def main() -> None:
    from _fleet_traffic import seconds_or_off

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="20 and 50 robots, 1 sim-minute")
    ap.add_argument("--robots", type=int, nargs="*", default=None)
    ap.add_argument("--minutes", type=float, default=None)
    ap.add_argument("--avoidance", nargs="*", default=["orca", "none"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--traffic", action="store_true",
                    help="issue 17: also run the PIBT traffic layer (fleet/traffic) with 360-beam lidar at 10 Hz, "
                         "collisions counted independently from ground-truth poses (_fleet_traffic.py)")
    ap.add_argument("--traffic-only", action="store_true", help="only the traffic-layer runs")
    ap.add_argument("--traffic-lidar", nargs="*", choices=("on", "off"), default=["on"],
                    help="traffic-layer runs with the 360-beam lidar on, off, or both (default on)")
    ap.add_argument("--window", type=int, default=1, help="traffic layer: moves a robot may have queued (default 1)")
    ap.add_argument("--priority", nargs="*", choices=("goal_age", "since_progress"), default=["goal_age"],
                    help="traffic layer: PIBT priority rule(s), one run each (default goal_age)")
    ap.add_argument("--rule", nargs="*", choices=tuple(RULES), default=["new"],
                    help="traffic layer: rules against long waits, one run each: old = none (window 2); l3 = the "
                         "third landing's (lanes: highway 4, lane_cost 3; aging: urgent after 12 s without "
                         "progress; yield aside; window 2); new = l3 with window --window (default 1) and robots "
                         "with a full window can still be pushed, the urgent ranked by time without progress (l4: "
                         "by time since they became urgent, the fourth landing's); cong = new with congestion-aware "
                         "routing (--congestion)")
    ap.add_argument("--congestion", type=float, default=4.0,
                    help="traffic layer, rule cong: toll per unit of recent occupancy for entering a cell "
                         "(congestion-aware routing, fleet/traffic/congestion.py; default 4)")
    ap.add_argument("--withdraw", nargs="*", choices=WITHDRAW, default=["crowded"],
                    help="traffic layer: withdraw unstarted moves, one run each: loops = planned loops; ahead = moves "
                         "ahead of urgent robots; both; flush = all, every --flush-s (re-plan); crowded = flush while "
                         "goals are held (default)")
    ap.add_argument("--flush-s", type=float, default=1.0,
                    help="traffic layer, --withdraw flush: period of the re-plan from the committed cells (default 1)")
    ap.add_argument("--one-way", nargs="*", choices=("off", "on"), default=["on"],
                    help="traffic layer: one-lane through corridors one-way (fleet/traffic/lanes.py), one run each")
    ap.add_argument("--admission", nargs="*", choices=ADMISSION, default=["bound"],
                    help="traffic layer: dispatch admission, one run each: aimd = new goals held (FIFO) while the "
                         "layer is congested, limit adapted AIMD-style (fleet/traffic/admission.py); park: held robots "
                         "wait on parking cells; bound (the default): park, and held goals crossing the way of a "
                         "robot in a wait stay held (fleet/traffic/admission_wait.py)")
    ap.add_argument("--urgent-cells", type=int, default=3,
                    help="traffic layer: urgency ends once a robot is this many cells closer than when it became "
                         "urgent (it may become urgent again); default 3")
    ap.add_argument("--keep-clear", nargs="*", choices=("off", "on"), default=["on"],
                    help="traffic layer: robots enter a crossing of aisles only with a way out, or after "
                         "--keep-clear-s at rest (fleet/traffic/crossings.py; default on), one run each")
    ap.add_argument("--keep-clear-s", type=float, default=4.0,
                    help="traffic layer: a robot kept out of a crossing this long at rest enters anyway (default 4)")
    ap.add_argument("--held-clear", nargs="*", choices=("off", "on"), default=["on"],
                    help="traffic layer: robots whose goals are held plan no move of their own into the way of a "
                         "robot in a wait (fleet/traffic/admission_wait.py; default on), one run each")
    ap.add_argument("--urgent-window", type=int, default=1,
                    help="traffic layer: moves an urgent robot may have planned ahead (default 1: --window)")
    ap.add_argument("--hold-ground-s", type=seconds_or_off, default=5.0,
                    help="traffic layer: a robot with a goal that has not come closer for this long is not pushed "
                         "back until it is urgent (fleet/traffic/priority.py; default 5; off: PIBT's pushes)")
    ap.add_argument("--baseline-minutes", type=float, default=None,
                    help="sim-minutes of the avoidance baselines (default: --minutes)")
    a = ap.parse_args()
    robots = a.robots or ([20, 50] if a.quick else [20, 50, 100])
    minutes = a.minutes or (1.0 if a.quick else 10.0)
    cols = ("robots", "avoidance", "done_per_min", "failed", "robot_collisions", "robot_contacts", "obstacle_hits",
            "near_misses", "deadlocks", "resolved", "rtf", "wall_s", "cpu_s")
    print(f"warehouse.world, {minutes:g} sim-minutes per run, seed {a.seed}")
    print(" | ".join(cols))
    with tempfile.TemporaryDirectory() as tmp:
        model = robot_model(Path(tmp))
        models = {"on": robot_model(Path(tmp), LIDAR_FULL, "diffbot_full.yaml"),
                  "off": robot_model(Path(tmp), LIDAR_OFF, "diffbot_nolidar.yaml")}
        for n in robots:
            if a.traffic or a.traffic_only:
                from _fleet_traffic import run_traffic

                tcols = ("robots", "avoidance", "done", "done_per_min", "in_progress", "robot_collisions",
                         "obstacle_hits", "world_contacts", "closest_robot_gap_m", "closest_obstacle_gap_m",
                         "deadlocks", "resolved", "unresolved", "longest_deadlock_s", "longest_open_s",
                         "cycle_waits", "longest_cycle_wait_s", "queue_waits", "longest_queue_wait_s", "classify_cpu_s",
                         "fields_computed", "withdrawn", "latency_p50_s", "latency_p95_s", "latency_max_s",
                         "oldest_open_task_s", "admission_limit", "lowest_limit", "held_now", "urgent_now",
                         "longest_hold_s", "layer_ms_per_tick", "rtf", "rtf_cpu", "wall_s", "cpu_s", "load",
                         "waits_over_20_s", "waits_over_25_s", "waits_over_30_s")
                print(" | ".join(tcols))
                for lid in a.traffic_lidar:
                    for prio, rule, wd, adm, ow, kc, hc in itertools.product(a.priority, a.rule, a.withdraw,
                                                                             a.admission, a.one_way, a.keep_clear,
                                                                             a.held_clear):
                        r = run_traffic(n, minutes, a.seed, models[lid], priority=prio,
                                        **{"window": a.window, "urgent_window": a.urgent_window, **RULES[rule]},
                                        congestion=a.congestion if rule == "cong" else 0.0,
                                        withdraw=wd, flush_s=a.flush_s, admission=adm, urgent_cells=a.urgent_cells,
                                        one_way=ow == "on", keep_clear=kc == "on", keep_clear_s=a.keep_clear_s,
                                        held_clear=hc == "on", hold_ground_s=a.hold_ground_s,
                                        lidar="360 beams 10 Hz" if lid == "on" else "off")
                        print(" | ".join(f"{r[c]:.2f}" if isinstance(r[c], float) else str(r[c]) for c in tcols),
                              flush=True)
                print(" | ".join(cols))
            if a.traffic_only:
                continue
            for av in a.avoidance:
                r = run(n, a.baseline_minutes or minutes, av, a.seed, model)
                print(" | ".join(f"{r[c]:.2f}" if isinstance(r[c], float) else str(r[c]) for c in cols), flush=True)
                if r["fail_reasons"]:
                    print(f"    failures: {r['fail_reasons']}", flush=True)


if __name__ == "__main__":
    main()
