"""MCP front door: tool latency (p50/p99) in memory and over stdio, next to the same FleetService operation
called directly (the baseline, measured in the same run; overhead = memory p50 − direct p50), response sizes
per response_format for a 100-robot fleet (tokens ≈ characters of the JSON text / 4), and the o200k tokens of
tools/list per toolset (the wire JSON an assistant reads; bpe-openai's bundled o200k_base vocabulary).

    .venv/bin/python benchmarks/mcp.py            # 50 calls per tool
    .venv/bin/python benchmarks/mcp.py --quick    # 10 calls per tool
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

# This file is named mcp.py: drop its own directory from the path so `import mcp` finds the SDK, not us.
HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE]
sys.path.insert(0, str(HERE.parent))

import anyio  # noqa: E402
from mcp.client import Client  # noqa: E402
from mcp.client.stdio import StdioServerParameters  # noqa: E402
from mcp_types import TextContent  # noqa: E402

from fleet import FleetConfig, FleetService  # noqa: E402
from mcp_server.server import build_server  # noqa: E402
from sim import Pose2D  # noqa: E402


# Latency with 10 robots by default (the sim keeps real time, so the service-mode queue wait is the MCP
# path's, not a backlog of physics; --robots changes it); sizes with 100.
def fleet(n: int) -> dict[str, Any]:
    return {"count": n, "formation": "grid", "centre": {"x": 0, "y": 0}, "spacing": 0.8}


# tool, arguments, the direct FleetService call it wraps (baseline)
CASES: list[tuple[str, dict[str, Any], Callable[[FleetService], Any]]] = [
    ("sim_status", {}, lambda s: s.status()),
    ("list_robots", {"response_format": "summary"}, lambda s: s.snapshot.summary()),
    ("get_robot_state", {"robot": "robot1"}, lambda s: (s.robot("robot1"), s.list_tasks("robot1"))),
    ("read_sensor", {"robot": "robot1", "sensor": "lidar"}, lambda s: s.read_sensor("robot1", "lidar")),
    ("step_simulation", {"steps": 10}, lambda s: s.step(10)),
    ("plan_path", {"robot": "robot1", "x": 4.5, "y": 4.5}, lambda s: s.plan_path("robot1", Pose2D(4.5, 4.5, 0))),
    ("get_camera_image", {"robot": "robot1"}, lambda s: s.render_camera("robot1")),
    ("get_occupancy_map", {}, lambda s: s.map_image()),
]
SIZES: list[tuple[str, dict[str, Any]]] = [
    ("list_robots", {}), ("fleet_status", {}), ("list_models", {}), ("read_sensor", {"robot": "robot1"}),
    ("plan_path", {"robot": "robot1", "x": 4.5, "y": 4.5}), ("get_robot_state", {"robot": "robot1"})]


def pct(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, round(q * (len(xs) - 1)))]


async def timed(n: int, fn: Callable[[], Awaitable[Any]]) -> list[float]:
    await fn()  # warm-up (first render, first plan)
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        await fn()
        out.append(1e3 * (time.perf_counter() - t0))
    return out


def text_len(r: Any) -> int:
    return sum(len(c.text) for c in r.content if isinstance(c, TextContent))


async def bench_client(c: Client, n: int) -> dict[str, list[float]]:
    out = {}
    for tool, args, _ in CASES:
        async def call(tool: str = tool, args: dict[str, Any] = args) -> None:
            r = await c.call_tool(tool, args)
            assert not r.is_error, r.content
        out[tool] = await timed(n, call)
    return out


async def toolset_tokens(svc: FleetService) -> list[tuple[str, int, int, int]]:
    """(toolset, tools, o200k tokens of tools/list, characters) per toolset, plus core and all."""
    import bpe_openai

    from mcp_server.tools import TOOLSETS

    enc = bpe_openai.get_encoding("o200k_base")
    rows = []
    for ts in ("core", "all", *TOOLSETS):
        async with Client(build_server(svc, toolsets=ts)) as c:
            res = await c.list_tools()
            wire = res.model_dump_json(by_alias=True, exclude_none=True)
            rows.append((ts, len(res.tools), len(enc.encode(wire)), len(wire)))
    return rows


async def run(n: int, robots: int) -> None:
    svc = FleetService(FleetConfig(world="empty", seed=0))
    tokens = await toolset_tokens(svc)
    server = build_server(svc)
    async with Client(server) as c:
        await c.call_tool("spawn_fleet", fleet(robots))
        await c.call_tool("step_simulation", {"steps": 20})
        mem = await bench_client(c, n)
        direct = {}
        for tool, _, fn in CASES:
            async def call(fn: Callable[[FleetService], Any] = fn) -> None:
                fn(svc)
            direct[tool] = await timed(n, call)
        await c.call_tool("reset_simulation", {})
        await c.call_tool("spawn_fleet", fleet(100))
        await c.call_tool("step_simulation", {"steps": 20})
        assert len(svc.snapshot.names) == 100
        sizes: list[tuple[str, int, int, int]] = []
        for tool, args in SIZES:
            n_s, n_n, n_f = [text_len(await c.call_tool(tool, {**args, "response_format": fmt}))
                             for fmt in ("summary", "normal", "full")]
            sizes.append((tool, n_s, n_n, n_f))
    svc.close()
    params = StdioServerParameters(command=str(Path(sys.executable).with_name("fleetnav")),
                                   args=["serve", "--world", "empty", "--workspace", "/tmp", "--toolsets", "all"])
    async with Client(params) as c:
        await c.call_tool("spawn_fleet", fleet(robots))
        await c.call_tool("step_simulation", {"steps": 20})
        stdio = await bench_client(c, n)

    print(f"Tool latency, ms ({robots} robots, empty world, {n} calls each; direct = the FleetService call alone,"
          " stdio = `fleetnav serve` in real time)")
    print(f"{'tool':20s} {'direct p50':>10s} {'memory p50':>10s} {'overhead':>9s} {'memory p99':>10s} "
          f"{'stdio p50':>10s} {'stdio p99':>10s}")
    for tool, _, _ in CASES:
        d = statistics.median(direct[tool])
        print(f"{tool:20s} {d:10.2f} {pct(mem[tool], .5):10.2f} {pct(mem[tool], .5) - d:9.2f} "
              f"{pct(mem[tool], .99):10.2f} {pct(stdio[tool], .5):10.2f} {pct(stdio[tool], .99):10.2f}")
    print("\ntools/list per toolset (o200k tokens of the wire JSON; `fleetnav serve` defaults to core)")
    print(f"{'toolset':12s} {'tools':>5s} {'tokens':>7s} {'chars':>7s}")
    for ts, n_tools, n_tok, n_chars in tokens:
        print(f"{ts:12s} {n_tools:5d} {n_tok:7d} {n_chars:7d}")
    print("\nResponse size, characters of the JSON text (≈ tokens × 4), 100 robots")
    print(f"{'tool':20s} {'summary':>9s} {'normal':>9s} {'full':>9s}   summary tokens")
    for tool, s, nrm, f in sizes:
        print(f"{tool:20s} {s:9d} {nrm:9d} {f:9d}   {s / 4:8.0f}")
    print(json.dumps({"tools_list_tokens": {r[0]: {"tools": r[1], "tokens": r[2]} for r in tokens},
                      "latency_ms": {t: {"direct_p50": statistics.median(direct[t]), "memory_p50": pct(mem[t], .5),
                                         "memory_p99": pct(mem[t], .99), "stdio_p50": pct(stdio[t], .5),
                                         "stdio_p99": pct(stdio[t], .99)} for t, _, _ in CASES},
                      "sizes_chars": {r[0]: dict(zip(("summary", "normal", "full"), r[1:], strict=True))
                                      for r in sizes}}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 calls per tool instead of 50")
    ap.add_argument("--robots", type=int, default=10, help="fleet size for the latency runs (sizes use 100)")
    args = ap.parse_args()
    anyio.run(run, 10 if args.quick else 50, args.robots)


if __name__ == "__main__":
    main()
