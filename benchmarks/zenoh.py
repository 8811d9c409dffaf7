"""Zenoh front door under load: N robots stream odometry (50 Hz) and scans (10 Hz) while agents command them.

    .venv/bin/python benchmarks/zenoh.py            # 100 robots, 10 agents × 10 robots at 10 Hz, 20 s windows
    .venv/bin/python benchmarks/zenoh.py --quick    # 20 robots, 2 agents, 5 s windows
    .venv/bin/python benchmarks/zenoh.py --lifecycle [--quick]  # agents' leases, rates, hung agents (issue 19)
    .venv/bin/python benchmarks/zenoh.py --stages --robot-cast rebuild,closed  # issue 17a: robots' Embree scene
                                                                               # rebuilt per cast (before) / not

Two windows on the same world, one after the other, with the same command load:
  baseline  the commands enter in-process (FleetService.submit → safety envelope), no Zenoh at all;
  zenoh     a ZenohBridge serves the world on 127.0.0.1; agent processes (fleet.agent SDK) publish cmd_vel and a
            subscriber process receives every robot's odom and scan.
Figures: command-to-applied latency p50/p99 (agent's send → the physics step that applies it: since issue 17 a
command reaches the world's command when the sim thread drains it, before the next physics step, not at the
10 Hz control tick), per stage (send → bridge receive → envelope → applied, `--stages`), dropped commands
(sent − received, target 0), publish
rate sustained (readings the world produced vs published vs received), CPU (cores busy) per process. The
machine is shared: the load average is printed with the figures.

Roles (the script starts itself in other processes): --role agents | subscriber.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

# This file is named zenoh.py (and benchmarks/ holds fleet.py): run as a script, its folder would shadow the
# `zenoh` and `fleet` packages, so it leaves sys.path before they are imported (inside the functions below).
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

ROOT = Path(__file__).resolve().parents[1]
SPACING = 3.0  # m between robots; each drives a 1 m-radius circle (v 0.3, w 0.3)
V, W = 0.3, 0.3


def lat(r: dict[str, Any], which: str) -> str:
    q = r["lat"][which]
    return f"{q['p50_ms']:.1f} / {q['p99_ms']:.1f}" if q["count"] else "n/a"


# ---- helper processes ---------------------------------------------------------------------------------------


def role_agents(ep: str, names: list[str], per_agent: int, duration: float, tag: str) -> None:
    """Agents of `per_agent` robots each, every robot commanded at 10 Hz wall for `duration` s."""
    from fleet.agent import Agent

    agents = [Agent(f"bench{tag}_{i}", connect=ep).open() for i in range(0, len(names), per_agent)]
    links = [a.robot(n, streams=()) for i, a in enumerate(agents) for n in names[i * per_agent:(i + 1) * per_agent]]
    print(json.dumps({"ready": True}), flush=True)
    cpu0, t0, sent = time.process_time(), time.monotonic(), 0
    k = 0
    while time.monotonic() < t0 + duration:
        for j, link in enumerate(links):  # each robot at 10 Hz, robots spread over the period (unsynchronised)
            time.sleep(max(0.0, t0 + 0.1 * (k + j / len(links)) - time.monotonic()))
            link.drive(V, W)
            sent += 1
        k += 1
    wall = time.monotonic() - t0
    for link in links:
        link.stop()
    sent += len(links)
    cpu = time.process_time() - cpu0
    for a in agents:
        a.close()
    print(json.dumps({"sent": sent, "cpu_cores": cpu / wall, "wall": wall}), flush=True)


def role_subscriber(ep: str, world: str, duration: float) -> None:
    import zenoh

    from fleet.zenoh_api import Keys
    from fleet.zenoh_config import loopback

    counts = {"odom": 0, "scan": 0, "bytes": 0}

    def count(kind: str) -> Any:
        def cb(s: zenoh.Sample) -> None:
            counts[kind] += 1
            counts["bytes"] += len(s.payload)
        return zenoh.handlers.Callback(cb, indirect=False)

    k = Keys(world)
    with zenoh.open(loopback(int(ep.rsplit(":", 1)[1]), listen=False).to_zenoh()) as s:
        subs = [s.declare_subscriber(k.robot_any(t), count(t)) for t in ("odom", "scan")]
        print(json.dumps({"ready": True}), flush=True)
        line = sys.stdin.readline()  # "go": the measurement window starts
        assert line.strip() == "go"
        c0, cpu0, t0 = dict(counts), time.process_time(), time.monotonic()
        sys.stdin.readline()  # "mark": the window ends
        wall, cpu = time.monotonic() - t0, time.process_time() - cpu0
        out: dict[str, Any] = {k2: counts[k2] - c0[k2] for k2 in counts} | {"wall": wall, "cpu_cores": cpu / wall}
        sys.stdin.readline()  # "stop": the world is paused; count until nothing more arrives (≤ 5 s)
        settle, total = time.monotonic() + 5.0, -1
        while total != counts["odom"] + counts["scan"] and time.monotonic() < settle:
            total = counts["odom"] + counts["scan"]
            time.sleep(0.3)
        out["total"] = total
        for sub in subs:
            sub.undeclare()
    print(json.dumps(out), flush=True)


def spawn_role(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, __file__, *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, cwd=ROOT)


def read_json(p: subprocess.Popen[str]) -> dict[str, Any]:
    assert p.stdout is not None
    while True:
        line = p.stdout.readline()
        if not line:
            raise RuntimeError(f"helper process exited ({p.wait()}) without a result")
        if line.startswith("{"):
            return dict(json.loads(line))


# ---- the server side -----------------------------------------------------------------------------------------


def make_service(n: int, beams: int, tmp: Path, lidar_phases: str = "spread", robot_cast: str = "closed") -> Any:
    import yaml

    from fleet import FleetConfig, FleetService
    from sim import Pose2D
    from sim.raycast_embree import EmbreeCaster

    spec = yaml.safe_load((ROOT / "configs" / "robots" / "diffbot.yaml").read_text())
    spec["sensors"]["lidar"]["beams"] = beams
    robot = tmp / "bench_robot.yaml"
    robot.write_text(yaml.safe_dump(spec))
    side = int(n ** 0.5 + 0.999)
    half = SPACING * side / 2 + 2
    svc = FleetService(FleetConfig(world="empty", seed=0, robot_model=str(robot), avoidance={"type": "none"},
                                   safety={"geofence": (-half, -half, half, half)}))
    svc.world.lidar_phases = lidar_phases  # before the spawns: they pick each robot's lidar phase
    for i in range(n):
        x, y = SPACING * (i % side - (side - 1) / 2), SPACING * (i // side - (side - 1) / 2)
        svc.spawn_robot(f"r{i:03d}", Pose2D(x, y, 0.0))
    # "closed": robots intersected in closed form (issue 17a); "rebuild": their Embree scene built every cast
    svc.world.rays.embree = EmbreeCaster(svc.world)
    svc.world.rays.embree.closed_form = robot_cast == "closed"
    return svc


class Window:
    """CPU, sim time and sensor readings produced over one measurement window."""

    def __init__(self, svc: Any) -> None:
        self.svc, self.readings = svc, 0
        self._unsub = svc.call(lambda: svc.world.subscribe(self._count, kinds=("odom", "scan")))

    def _count(self, _: object) -> None:
        self.readings += 1

    def __enter__(self) -> Window:
        self.svc.resume(1.0)  # re-anchor the real-time clock: no catch-up from before the window counts in it
        self.cpu0, self.t0, self.sim0, self.r0 = time.process_time(), time.monotonic(), self.svc.snapshot.time, \
            self.readings
        return self

    def __exit__(self, *exc: object) -> None:
        self.wall = time.monotonic() - self.t0
        self.cpu = (time.process_time() - self.cpu0) / self.wall
        self.rtf = (self.svc.snapshot.time - self.sim0) / self.wall
        self.produced = (self.readings - self.r0) / self.wall
        self.svc.call(self._unsub)


def baseline(svc: Any, names: list[str], per_agent: int, duration: float) -> dict[str, Any]:
    """The same command load entering in-process: the latency floor (control tick) and the sim's own CPU."""
    from fleet.zenoh_bridge.gate import Gate

    gate = Gate(svc, lockstep=False, timeout_s=1.0, on_tick=lambda *_: None, on_hung=lambda *_: None)
    svc.call(lambda: setattr(svc, "control_gate", gate))
    svc.call(lambda: svc.step_listeners.append(gate.stepped))  # applied = the physics step after acceptance
    stop = threading.Event()

    def commander() -> None:
        k, t0 = 0, time.monotonic()
        while not stop.is_set():
            for i, name in enumerate(names):  # paced like the agents: each robot at 10 Hz, spread over the period
                stop.wait(max(0.0, t0 + 0.1 * (k + i / len(names)) - time.monotonic()))
                sent = time.time()

                def apply(name: str = name, i: int = i, sent: float = sent) -> None:
                    svc.drive(name, V, W, client=f"base{i // per_agent}")
                    gate.applied(sent, sent)  # in-process: received the moment it is sent

                gate.run(apply)
            k += 1

    th = threading.Thread(target=commander, daemon=True)
    th.start()
    stop.wait(1.0)  # warm-up
    with Window(svc) as w:
        stop.wait(duration)
    stop.set()
    th.join()
    svc.call(lambda: setattr(svc, "control_gate", None))
    svc.call(lambda: svc.step_listeners.remove(gate.stepped))
    for c in range(0, len(names), per_agent):  # hand the robots back: the agents take them over next
        svc.release_client(f"base{c // per_agent}", "baseline window over")
    return {"rtf": w.rtf, "cpu": w.cpu, "lat": gate.latency_stats(), "produced": w.produced}


def over_zenoh(svc: Any, names: list[str], per_agent: int, duration: float, procs: int) -> dict[str, Any]:
    from fleet.zenoh_bridge import ZenohBridge
    from fleet.zenoh_config import StreamsConfig, loopback

    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = int(sock.getsockname()[1])
    ep = f"tcp/127.0.0.1:{port}"
    # odom and scans as asked; the IMU stream (100 Hz) stays off so the figures are about those two
    with ZenohBridge(svc, loopback(port, listen=True, streams=StreamsConfig(imu=False))) as bridge:
        sub = spawn_role("--role", "subscriber", "--connect", ep, "--world", bridge.keys.world)
        read_json(sub)
        chunk = -(-len(names) // procs)
        agents = [spawn_role("--role", "agents", "--connect", ep, "--robots", ",".join(names[i:i + chunk]),
                             "--per-agent", str(per_agent), "--duration", str(duration + 3), "--tag", str(i))
                  for i in range(0, len(names), chunk)]
        for a in agents:
            read_json(a)
        time.sleep(1.0)  # warm-up: every agent sending
        for q in (bridge.gate.latencies, bridge.gate.accept_latencies, bridge.gate.receive_latencies,
                  bridge.gate.envelope_latencies, bridge.gate.apply_latencies):
            q.clear()
        assert sub.stdin is not None
        sub.stdin.write("go\n")
        sub.stdin.flush()
        with Window(svc) as w:
            pub0 = bridge.streams.published
            time.sleep(duration)
            pub1 = bridge.streams.published
            sub.stdin.write("mark\n")
            sub.stdin.flush()
        svc.pause()  # no more readings: whatever was published is delivered or lost by now
        time.sleep(0.5)
        published_total = bridge.streams.published
        sub.stdin.write("stop\n")
        sub.stdin.flush()
        published = (pub1 - pub0) / w.wall
        received = read_json(sub)
        results = [read_json(a) for a in agents]
        sent = sum(int(r["sent"]) for r in results)
        deadline = time.monotonic() + 10
        while bridge.stats()["commands"]["received"] < sent and time.monotonic() < deadline:
            time.sleep(0.05)  # the last commands may still be in flight
        st = bridge.stats()
        lat = bridge.gate.latency_stats()
        for p in (sub, *agents):
            p.wait(timeout=10)
    return {"rtf": w.rtf, "cpu": w.cpu, "lat": lat, "produced": w.produced, "published": published,
            "received": (received["odom"] + received["scan"]) / received["wall"], "mbps": 8e-6 * received["bytes"]
            / received["wall"], "sub_cpu": received["cpu_cores"], "agents_cpu": sum(r["cpu_cores"] for r in results),
            "samples_lost": published_total - received["total"], "samples": published_total,
            "sent": sent, "got": st["commands"]["received"], "rejected": st["commands"]["rejected"],
            "lost": st["commands"]["lost"], "malformed": st["commands"]["malformed"]}


def main() -> None:
    if "--lifecycle" in sys.argv:  # issue 19: leases, rate limits, hung agents (benchmarks/zenoh_agents.py)
        sys.argv.remove("--lifecycle")
        import runpy

        runpy.run_path(str(ROOT / "benchmarks" / "zenoh_agents.py"), run_name="__main__")
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--robots", default=None, help="(roles) comma-separated robot names; (main) how many robots")
    ap.add_argument("--beams", type=int, default=90, help="lidar beams (360 cannot run 100 robots at 1x here)")
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--role", choices=("agents", "subscriber"))
    ap.add_argument("--connect", default="")
    ap.add_argument("--world", default="empty")
    ap.add_argument("--per-agent", type=int, default=10)
    ap.add_argument("--tag", default="0")
    ap.add_argument("--stages", action="store_true",
                    help="also print the per-stage latency (send → receive → envelope → applied) and the issue-17 "
                         "targets (world ≥ 0.98× real time, command→applied p99 ≤ 15 ms, 0 dropped)")
    ap.add_argument("--json", type=Path, help="write every figure to this JSON file")
    ap.add_argument("--lidar-phases", default="spread",
                    help="comma-separated lidar phase policies, one whole measurement each, in this order: 'spread' "
                         "(each physics step casts ~1/10 of the fleet's lidars) and/or 'aligned' (all in one step, "
                         "the behaviour before issue 17b)")
    ap.add_argument("--robot-cast", default="rebuild,closed",
                    help="comma-separated, one whole measurement each, in this order: 'rebuild' (the robots' Embree "
                         "scene built in every cast: before issue 17a) and/or 'closed' (robots in closed form, now)")
    a = ap.parse_args()
    if a.role == "agents":
        return role_agents(a.connect, a.robots.split(","), a.per_agent, float(a.duration), a.tag)
    if a.role == "subscriber":
        return role_subscriber(a.connect, a.world, 0.0)
    n = int(a.robots) if a.robots else (20 if a.quick else 100)
    duration = a.duration or (5.0 if a.quick else 20.0)
    procs = 1 if a.quick else 2
    runs: dict[str, Any] = {}
    for phases in a.lidar_phases.split(","):
        for cast in a.robot_cast.split(","):
            with tempfile.TemporaryDirectory() as tmp:
                svc = make_service(n, a.beams, Path(tmp), phases, cast)
                names = list(svc.snapshot.names)
                svc.start("realtime", 1.0)
                try:
                    base = baseline(svc, names, a.per_agent, duration)
                    zen = over_zenoh(svc, names, a.per_agent, duration, procs)
                finally:
                    svc.close()
            print(f"\n==== lidar phases: {phases}, robots in the ray cast: {cast}")
            report(n, a.beams, a.per_agent, duration, procs, base, zen)
            if a.stages:
                report_stages(base, zen)
            runs[f"{phases}/{cast}"] = {"baseline": base, "zenoh": zen, "load": os.getloadavg()}
    if a.json:
        a.json.write_text(json.dumps({"robots": n, "beams": a.beams, "runs": runs}, indent=1, default=str),
                          encoding="utf-8")


def report_stages(b: dict[str, Any], z: dict[str, Any]) -> None:
    """Issue 17: where a command's time goes, and the targets held to the Zenoh window."""
    print(f"\n{'command stages (p50 / p99, ms)':34}{'in-process (baseline)':>24}{'over zenoh':>26}")
    for name, key in (("send → bridge received", "receive"), ("received → envelope", "envelope"),
                      ("envelope → applied (physics step)", "apply"), ("send → applied", "applied")):
        print(f"{name:34}{lat(b, key):>24}{lat(z, key):>26}")
    p99 = z["lat"]["applied"]["p99_ms"]
    dropped = z["sent"] - z["got"]
    checks = [("world real-time factor ≥ 0.98", f"{z['rtf']:.3f}", z["rtf"] >= 0.98),
              ("command→applied p99 ≤ 15 ms", f"{p99}", p99 is not None and p99 <= 15.0),
              ("0 commands dropped", f"{dropped}", dropped == 0 and z["lost"] == 0)]
    print()
    for name, value, ok in checks:
        print(f"{name:34}{value:>24}{'met' if ok else 'NOT MET':>26}")


def report(n: int, beams: int, per_agent: int, duration: float, procs: int, b: dict[str, Any],
           z: dict[str, Any]) -> None:
    expected = n * (50 + 10)
    print(f"\nzenoh front door: {n} robots (odom 50 Hz, scan {beams} beams 10 Hz), {-(-n // per_agent)} agents × "
          f"{per_agent} robots at 10 Hz in {procs} process(es), {duration:g} s windows, 1x real time")
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores (shared machine)\n")
    print(f"{'':34}{'in-process (baseline)':>24}{'over zenoh':>26}")
    rows = [
        ("real-time factor", f"{b['rtf']:.2f}", f"{z['rtf']:.2f}"),
        ("server CPU, cores busy", f"{b['cpu']:.2f}", f"{z['cpu']:.2f} (+{z['cpu'] - b['cpu']:.2f} bridge)"),
        ("command→envelope p50 / p99, ms", lat(b, "accepted"), lat(z, "accepted")),
        ("command→applied p50 / p99, ms", lat(b, "applied"), lat(z, "applied")),
        ("commands sent / received", "", f"{z['sent']} / {z['got']}"),
        ("dropped (sent − received)", "", f"{z['sent'] - z['got']} (seq gaps {z['lost']})"),
        ("rejected / malformed", "", f"{z['rejected']} / {z['malformed']}"),
        ("readings produced /s (1x: " + f"{expected})", f"{b['produced']:.0f}", f"{z['produced']:.0f}"),
        ("published /s", "", f"{z['published']:.0f}"),
        ("received by subscriber /s", "", f"{z['received']:.0f} ({z['mbps']:.1f} Mbit/s)"),
        ("samples lost, whole run", "", f"{z['samples_lost']} of {z['samples']}"),
        ("subscriber / agents CPU, cores", "", f"{z['sub_cpu']:.2f} / {z['agents_cpu']:.2f}"),
    ]
    for name, left, right in rows:
        print(f"{name:34}{left:>24}{right:>26}")


if __name__ == "__main__":
    main()
