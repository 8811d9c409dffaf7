"""How fast a warehouse world loads: SDF parse time, and PyBullet build time against a naive baseline.

    .venv/bin/python benchmarks/sdf_build.py            # 40 m and 80 m warehouses, 5 repeats
    .venv/bin/python benchmarks/sdf_build.py --quick    # 40 m only, 2 repeats

Baseline (measured in the same run): raw PyBullet the way a naive loader does it — one
createCollisionShape + createVisualShape + createMultiBody per collision element, nothing shared.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import pybullet as p

from sim.bodies import build_model, build_models
from sim.sdf_parser import parse_sdf
from sim.sdf_writer import save_sdf
from sim.types import Box, Cylinder, Plane, Sphere, WorldDescription
from sim.worldgen import warehouse


def naive_build(client: int, world: WorldDescription) -> int:
    n = 0
    for m in world.models:
        for link, c, wp in m.world_collisions():
            g = c.geometry
            if isinstance(g, Box):
                kw = {"shapeType": p.GEOM_BOX, "halfExtents": [s / 2 for s in g.size]}
            elif isinstance(g, Cylinder):
                kw = {"shapeType": p.GEOM_CYLINDER, "radius": g.radius}
            elif isinstance(g, Sphere):
                kw = {"shapeType": p.GEOM_SPHERE, "radius": g.radius}
            elif isinstance(g, Plane):
                kw = {"shapeType": p.GEOM_PLANE}
            else:
                continue
            col = p.createCollisionShape(**kw, physicsClientId=client)
            vis = p.createVisualShape(**kw, rgbaColor=link.visuals[0].rgba if link.visuals else None,
                                      physicsClientId=client) if not isinstance(g, Plane) else -1
            p.createMultiBody(0, col, vis, basePosition=wp.position, baseOrientation=wp.quaternion,
                              physicsClientId=client)
            n += 1
    return n


def timed(fn: Callable[[int], object], repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        client = p.connect(p.DIRECT)
        t = time.perf_counter()
        out = fn(client)
        times.append(time.perf_counter() - t)
        p.disconnect(client)
    return statistics.median(times), out


def run(size: float, repeats: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "warehouse.world"
        save_sdf(warehouse(size=size), path)
        parse_times = []
        for _ in range(repeats):
            t = time.perf_counter()
            world = parse_sdf(path)
            parse_times.append(time.perf_counter() - t)
    shelves = sum(1 for m in world.models if m.name.startswith("shelf_"))
    t_naive, n_naive = timed(lambda c: naive_build(c, world), repeats)
    t_each, built_each = timed(lambda c: [build_model(c, m, ground_texture=world.ground_material)
                                          for m in world.models], repeats)
    t_batch, built = timed(lambda c: build_models(c, world.models, ground_texture=world.ground_material), repeats)
    assert isinstance(built, list) and isinstance(built_each, list)
    bodies = sum(len(b.body_uids) for b in built)
    print(f"warehouse {size:.0f} x {size:.0f} m: {len(world.models)} models ({shelves} shelves), "
          f"{sum(len(lk.collisions) for m in world.models for lk in m.links)} collision elements")
    print(f"  parse_sdf                        {1000 * statistics.median(parse_times):8.1f} ms")
    print(f"  baseline: naive raw PyBullet     {1000 * t_naive:8.1f} ms  ({n_naive} bodies)")
    print(f"  build_model, one call per model  {1000 * t_each:8.1f} ms  ({bodies} bodies)")
    print(f"  build_models (shared + batched)  {1000 * t_batch:8.1f} ms  ({bodies} bodies)")
    print(f"  speed-up over baseline: {t_naive / t_each:.1f}x one by one, {t_naive / t_batch:.1f}x batched")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="40 m warehouse only, 2 repeats")
    args = ap.parse_args()
    for size in (40.0,) if args.quick else (40.0, 80.0):
        run(size, 2 if args.quick else 5)


if __name__ == "__main__":
    main()
