"""The World's ray-casting backends: Embree (fleets; sim/raycast_embree.py) and PyBullet rayTestBatch (the
reference). They agree within 1 mm on flat geometry; on curved shapes Embree is exact and Bullet's GJK ray test
is off by up to a few mm (docs/benchmarks-sim.md)."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet as p

from sim.errors import ErrorCode, FleetError, unknown_name

if TYPE_CHECKING:
    from sim.raycast_layout import RayLayout
    from sim.world import World

MAX_RAYS_PER_CALL = 16_000  # rayTestBatch returns nothing at exactly 16,384 rays and raises above it
RAYCASTERS = ("embree", "pybullet")
log = logging.getLogger("fleetnav.sim")


class RayBackends:
    """The selected backend (`name`) and the Embree caster, built on first use and kept across switches."""

    def __init__(self, world: World, name: str) -> None:
        self.world = world
        self.embree: Any = None
        self.select(name)

    def select(self, name: str) -> None:
        if name not in RAYCASTERS:
            raise unknown_name("ray caster", name, RAYCASTERS, ErrorCode.INVALID_ARGUMENT)
        self.name = name

    def cast(self, origins: np.ndarray, ends: np.ndarray, layout: RayLayout | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
        """(hit fraction in [0, 1], body uid or -1) per ray, by the selected backend. `layout` describes how
        the rays were built (a lidar's fans); rayTestBatch does not use it."""
        if self.name == "embree":
            if self.embree is None:
                from sim.raycast_embree import EmbreeCaster

                self.embree = EmbreeCaster(self.world)
            try:
                return self.embree.cast(origins, ends, layout)
            except FleetError as exc:  # geometry Embree cannot read back (a concave mesh with no file): the
                if exc.code is not ErrorCode.UNSUPPORTED:  # reference caster serves this world instead
                    raise
                log.warning("ray casting falls back to PyBullet for world '%s': %s", self.world.name, exc.message)
                self.name = "pybullet"
        return cast_pybullet(self.world.client, origins, ends)


def cast_pybullet(client: int, origins: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PyBullet rayTestBatch, split into ≤16,000-ray calls."""
    n = len(origins)
    fractions = np.ones(n)
    uids = np.full(n, -1, dtype=np.int64)
    for a in range(0, n, MAX_RAYS_PER_CALL):
        b = min(n, a + MAX_RAYS_PER_CALL)
        res = p.rayTestBatch(origins[a:b], ends[a:b], numThreads=0, physicsClientId=client)
        uids[a:b] = [r[0] for r in res]
        fractions[a:b] = [r[2] for r in res]
    return fractions, uids
