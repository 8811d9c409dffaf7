"""MCP call overhead A/B: in-memory p50 of cheap tools (where the MCP path is all the cost) next to the direct
FleetService call, for this tree or another checkout of fleetnav given as an argument, so a change's
overhead is compared in one run on the same (shared, loaded) machine:

    git archive <base-commit> | tar -x -C /tmp/base
    for t in /tmp/base . /tmp/base .; do .venv/bin/python benchmarks/mcp_overhead.py $t; done
    .venv/bin/python benchmarks/mcp_overhead.py . --threaded     # service mode (sim thread in real time)
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


async def measure(threaded: bool, calls: int) -> dict[str, Any]:
    from mcp.client import Client

    from fleet import FleetConfig, FleetService
    from mcp_server.server import build_server
    from sim import Pose2D

    svc = FleetService(FleetConfig(world="empty", workspace=tempfile.mkdtemp()))
    for i in range(10):
        svc.spawn_robot(f"robot{i + 1}", Pose2D(i * 0.8, 0, 0))
    if threaded:
        svc.start("realtime", 1.0)
    out: dict[str, Any] = {}
    async with Client(build_server(svc)) as c:
        cases: list[tuple[str, dict[str, Any], Callable[[], Any]]] = [
            ("sim_status", {}, lambda: svc.call(svc.status)),
            ("get_robot_state", {"robot": "robot1"}, lambda: svc.call(lambda: svc.list_tasks("robot1"))),
            ("list_robots", {}, lambda: svc.snapshot.summary()),
            # a typed task spec: the MCP union, then the service's params model (issue 16; the queue
            # holds 200, so --calls ≤ 99)
            ("queue_task", {"spec": {"type": "go_to", "params": {"goal": {"x": 2.0, "y": 1.0}}}},
             lambda: svc.queue_task("go_to", {"goal": {"x": 2.0, "y": 1.0}}))]
        for tool, args, direct in cases:
            await c.call_tool(tool, args)
            mcp_ms, direct_ms = [], []
            for _ in range(calls):
                t0 = time.perf_counter()
                await c.call_tool(tool, args)
                mcp_ms.append(1e3 * (time.perf_counter() - t0))
                t0 = time.perf_counter()
                direct()
                direct_ms.append(1e3 * (time.perf_counter() - t0))
            m, d = statistics.median(mcp_ms), statistics.median(direct_ms)
            out[tool] = {"mcp_p50_ms": round(m, 3), "direct_p50_ms": round(d, 3), "overhead_ms": round(m - d, 3)}
    svc.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tree", nargs="?", default=str(Path(__file__).resolve().parents[1]), help="fleetnav checkout")
    ap.add_argument("--threaded", action="store_true", help="run the sim thread (service mode)")
    ap.add_argument("--calls", type=int, default=60)
    args = ap.parse_args()
    here = Path(__file__).resolve().parent
    sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != here]  # `import mcp` is the SDK
    sys.path.insert(0, str(Path(args.tree).resolve()))
    print(json.dumps({"tree": args.tree, "threaded": args.threaded, **asyncio.run(measure(args.threaded, args.calls))}))


if __name__ == "__main__":
    main()
