"""Zenoh agents' lifecycle (issue 19): leases that follow the agent's life, fleet controllers not throttled,
hung agents noticed. Agents are separate processes (tests/fleet/zenoh_agent_proc.py) on loopback.

    .venv/bin/python benchmarks/zenoh.py --lifecycle            # or: python benchmarks/zenoh_agents.py
    .venv/bin/python benchmarks/zenoh_agents.py --quick         # fewer trials

Figures, each beside a baseline from the same run:
  quick exit      session closes right after a command → lease free (world's release event − agent's close()
                  call, wall ms) over 20 trials; baseline: an agent without a liveliness token (a bare Zenoh
                  publisher), freed only by the idle expiry
  idle holder     connected but silent → freed after (configured expiry, s)
  hung agent      SIGSTOP → `agent_unresponsive` (ms; bound: 2 heartbeats) and the deadman's stop (cmd_v = 0)
  fleet control   one agent, 100 robots at 10 Hz for 5 s → rejected commands; baseline: the old limits
                  (200 commands/s per agent, no per-robot limit)
  race            two agents for one robot → refusals naming the other, overlaps (must be 0)
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

# benchmarks/ holds zenoh.py and fleet.py: run as a script, this folder would shadow the real packages
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

ROOT = Path(__file__).resolve().parents[1]
PROC = ROOT / "tests" / "fleet" / "zenoh_agent_proc.py"
sys.path.insert(0, str(ROOT))


def agent(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, str(PROC), *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True, cwd=ROOT)


def line(p: subprocess.Popen[str]) -> dict[str, Any]:
    assert p.stdout is not None
    text = p.stdout.readline()
    if not text:
        raise RuntimeError(f"agent process exited ({p.wait()}) without a result")
    return dict(json.loads(text))


def wait(pred: Any, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while not pred():
        if time.monotonic() > end:
            return False
        time.sleep(0.002)
    return True


def served(**kw: Any) -> Any:
    from tests.fleet.zenoh_util import served as _served

    return _served(**kw)


def events_at(svc: Any, kind: str) -> dict[str, float]:
    """client → wall time.time() of the latest `kind` event naming it (recorded on the sim thread)."""
    seen: dict[str, float] = {}
    svc.events.subscribe(lambda ev: seen.__setitem__(ev.data.get("client") or ev.data.get("agent"), time.time()),
                         kinds=(kind,))
    return seen


def quick_exit(trials: int) -> dict[str, Any]:
    with served(world="empty", robots={"r1": (0.0, 0.0, 0.0)}) as (svc, _, ep):
        lost = events_at(svc, "client_lost")
        p = agent("quick", ep, "r1", str(trials))
        lat: list[float] = []
        for i in range(trials):
            msg = line(p)
            name = msg["agent"]
            wait(lambda: name in lost, 5.0)  # noqa: B023
            lat.append(1e3 * (lost.get(name, float("inf")) - msg["closing_at"]))  # from the agent's close() call
            time.sleep(0.05)
            assert svc.safety.holder("r1") is None, f"trial {i}: a late command took the lease again"
            if i + 1 < trials:
                assert p.stdin is not None
                p.stdin.write("next\n")
                p.stdin.flush()
        p.wait(timeout=10)
    return {"trials": trials, "within_100ms": sum(x <= 100 for x in lat), "p50_ms": statistics.median(lat),
            "max_ms": max(lat)}


def quick_exit_baseline(trials: int, idle_s: float) -> dict[str, Any]:
    """A bare Zenoh publisher (no SDK, no liveliness token): only the idle expiry frees the lease."""
    import zenoh

    from fleet.zenoh_config import AgentsConfig, ZenohConfig

    freed: list[float] = []
    with served(world="empty", robots={"r1": (0.0, 0.0, 0.0)},
                agents=AgentsConfig(lease_idle_s=idle_s)) as (svc, bridge, ep):
        for i in range(trials):
            with zenoh.open(ZenohConfig(connect=[ep], mode="client", multicast_scouting=False).to_zenoh()) as s:
                s.put(bridge.keys.robot("r1", "cmd_vel"), json.dumps({"v": 0.1, "w": 0.0, "agent": f"bare{i}"}))
                wait(lambda: svc.safety.holder("r1") == f"bare{i}", 5.0)  # noqa: B023
            t0 = time.time()
            wait(lambda: svc.safety.holder("r1") is None, idle_s + 5)
            freed.append(1e3 * (time.time() - t0))
    return {"trials": trials, "p50_ms": statistics.median(freed), "max_ms": max(freed)}


def idle_holder(idle_s: float) -> dict[str, Any]:
    from fleet.zenoh_config import AgentsConfig

    with served(world="empty", robots={"r1": (0.0, 0.0, 0.0)},
                agents=AgentsConfig(lease_idle_s=idle_s)) as (svc, _, ep):
        p = agent("idle", ep, "r1", str(idle_s + 10))
        acquired = line(p)["acquired_at"]
        wait(lambda: svc.safety.holder("r1") is None, idle_s + 5)
        freed = time.time() - acquired
        p.kill()
        p.wait()
    return {"expiry_s": idle_s, "freed_after_s": freed}


def hung(trials: int, hz: float) -> dict[str, Any]:
    noticed, stopped = [], []
    with served(world="empty", robots={"r1": (0.0, 0.0, 0.0)}) as (svc, _, ep):
        for _ in range(trials):
            seen = events_at(svc, "agent_unresponsive")
            p = agent("hold", ep, "r1", "60", str(hz))
            line(p)
            wait(lambda: svc.snapshot.robot("r1").cmd_v > 0.2, 10)
            time.sleep(0.5)
            t0 = time.time()
            os.kill(p.pid, signal.SIGSTOP)
            wait(lambda: "holder" in seen, 5)  # noqa: B023
            noticed.append(1e3 * (seen.get("holder", float("inf")) - t0))
            wait(lambda: svc.snapshot.robot("r1").cmd_v == 0.0, 5)
            stopped.append(1e3 * (time.time() - t0))
            os.kill(p.pid, signal.SIGCONT)
            p.kill()
            p.wait()
            wait(lambda: svc.safety.holder("r1") is None, 5)
    return {"trials": trials, "bound_ms": 2e3 / hz, "within_bound": sum(x <= 2e3 / hz for x in noticed),
            "noticed_p50_ms": statistics.median(noticed), "noticed_max_ms": max(noticed),
            "deadman_p50_ms": statistics.median(stopped), "deadman_max_ms": max(stopped)}


def fleet_control(n: int, hz: float, seconds: float, old_limits: bool) -> dict[str, Any]:
    from fleet.zenoh_config import AgentsConfig

    robots = {f"f{i}": (-9.0 + 2.0 * (i % 10), -9.0 + 2.0 * (i // 10), 0.0) for i in range(n)}
    policy = AgentsConfig(agent_rate_hz=200, robot_rate_hz=1e9) if old_limits else AgentsConfig()
    with served(world="empty", robots=robots, fleet={"avoidance": {"type": "none"}},
                agents=policy) as (_, bridge, ep):
        p = agent("fleet", ep, str(n), str(hz), str(seconds))
        res = line(p)
        p.wait(timeout=30)
        st = bridge.commands.stats
        wait(lambda: st.applied + st.rejected >= res["sent"], 10)
        return {"sent": res["sent"], "applied": st.applied, "rejected": st.rejected,
                "example": res["errors"][0] if res["errors"] else ""}


def race(seconds: float) -> dict[str, Any]:
    with served(world="empty", robots={"r1": (0.0, 0.0, 0.0)}) as (_, _b, ep):
        ps = [agent("race", ep, "r1", name, str(seconds), "4", str(k)) for k, name in enumerate(("ann", "bob"))]
        logs = {(m := line(p))["agent"]: m["log"] for p in ps}
        for p in ps:
            p.wait()
    other = {"ann": "bob", "bob": "ann"}
    refusals = [(me, e) for me, log in logs.items() for e in log if e.get("ok") is False]
    naming = sum(f"client '{other[me]}'" in e["message"] for me, e in refusals)
    overlaps = 0
    for me, log in logs.items():
        start = None
        for e in log:
            if e.get("ok") and start is None:
                start = e["t1"]
            elif e.get("release") and start is not None:
                overlaps += sum(1 for b in logs[other[me]] if b.get("ok") and b["t0"] >= start and b["t1"] <= e["t0"])
                start = None
            elif e.get("ok") is False:
                start = None
    return {"accepted": sum(1 for log in logs.values() for e in log if e.get("ok")),
            "handovers": sum(1 for log in logs.values() for e in log if e.get("release")),
            "refusals": len(refusals), "naming_holder": naming, "overlaps": overlaps}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer trials")
    a = ap.parse_args()
    trials = 5 if a.quick else 20
    print(f"zenoh agents' lifecycle, loopback; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores "
          "(shared machine)\n", flush=True)
    q = quick_exit(trials)
    qb = quick_exit_baseline(2 if a.quick else 3, 3.0)
    print(f"quick exit → lease free      {q['within_100ms']}/{q['trials']} within 100 ms, p50 {q['p50_ms']:.1f} ms, "
          f"max {q['max_ms']:.1f} ms   | baseline (no liveliness token, idle expiry 3 s): p50 "
          f"{qb['p50_ms']:.0f} ms, max {qb['max_ms']:.0f} ms", flush=True)
    ih = idle_holder(1.0)
    print(f"idle holder → lease free     after {ih['freed_after_s']:.2f} s (expiry {ih['expiry_s']:g} s) "
          "| baseline (before issue 19): 30 s", flush=True)
    h = hung(3 if a.quick else 5, 4.0)
    print(f"SIGSTOP → agent_unresponsive {h['within_bound']}/{h['trials']} within {h['bound_ms']:.0f} ms "
          f"(2 heartbeats at 4 Hz), p50 {h['noticed_p50_ms']:.0f} ms, max {h['noticed_max_ms']:.0f} ms "
          f"| deadman stop (cmd 0): p50 {h['deadman_p50_ms']:.0f} ms, max {h['deadman_max_ms']:.0f} ms", flush=True)
    f = fleet_control(100, 10.0, 5.0, old_limits=False)
    fb = fleet_control(100, 10.0, 5.0, old_limits=True)
    print(f"fleet controller 100 × 10 Hz {f['rejected']} of {f['sent']} rejected ({f['applied']} applied) "
          f"| baseline (200/s per agent): {fb['rejected']} of {fb['sent']} rejected", flush=True)
    if fb["example"]:
        print(f"  baseline rejection says: {fb['example']}")
    r = race(3.0 if a.quick else 6.0)
    print(f"two agents race for r1       {r['accepted']} accepted, {r['handovers']} hand-overs, {r['refusals']} "
          f"refusals, {r['naming_holder']} naming the holder, {r['overlaps']} overlaps", flush=True)


if __name__ == "__main__":
    threading.current_thread().name = "bench"
    main()
