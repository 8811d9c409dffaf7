"""How a sweeping sensor laid out a batch of rays (a lidar's fans), handed to the ray caster beside the bare
rays so it never has to recover the fans from them (sim/raycast_robots.py group_rays: headings and reductions
over every ray).

Fan k is rays [start[k], start[k] + count[k]): horizontal rays from the centre (x, y, z), ray j heading
heading[k] + j * step[k], starting range_min[k] out along it and ending at range_max[k]. The PyBullet backend
ignores the layout; the Embree one builds its ray groups from it (layout_groups) after checking that the
first and last ray of every fan are where the layout says.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.raycast_robots import EVEN_TOL, TWO_PI, RayGroups

CHECK_TOL = 1e-6  # m: a fan's first and last ray must start and end this close to where the layout puts them


@dataclass(frozen=True)
class RayLayout:
    """G planar fans covering a batch of rays in order (arrays of length G)."""

    start: np.ndarray  # int64: index of the fan's first ray
    count: np.ndarray  # int64: rays in the fan
    x: np.ndarray  # fan centre (the lidar), m
    y: np.ndarray
    z: np.ndarray
    heading: np.ndarray  # rad: heading of the fan's first ray
    step: np.ndarray  # rad: heading increment between consecutive rays (> 0)
    range_min: np.ndarray  # m: rays start this far out along their heading
    range_max: np.ndarray  # m: and end this far out

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """The (origins, ends) this layout describes (headings by multiplication, so within ~1e-15 rad of
        the lidar's angle addition)."""
        k = np.repeat(np.arange(self.start.size), self.count)
        j = np.arange(k.size) - np.repeat(self.start - self.start[0], self.count)
        a = self.heading[k] + j * self.step[k]
        c, s = np.cos(a), np.sin(a)
        out = []
        for r in (self.range_min[k], self.range_max[k]):
            out.append(np.column_stack([self.x[k] + r * c, self.y[k] + r * s, self.z[k]]))
        return out[0], out[1]


def _bad(message: str) -> FleetError:
    return FleetError(ErrorCode.INVALID_ARGUMENT, f"ray layout: {message}",
                      "pass the layout the rays were built from, or cast the bare rays without one")


def _within(a: np.ndarray, b: np.ndarray) -> bool:
    """np.allclose(a, b, rtol=0, atol=CHECK_TOL), its overhead spared when every difference is finite and small
    (checked every cast)."""
    return bool((np.abs(a - b) <= CHECK_TOL).all()) or np.allclose(a, b, rtol=0, atol=CHECK_TOL)


def layout_groups(layout: RayLayout, o: np.ndarray, d: np.ndarray) -> RayGroups:
    """The ray groups of sim/raycast_robots.py straight from the layout: one group per fan, its centre the
    lidar, every origin range_min from it (spread), every ray line through it (offset 0), headings evenly
    spaced from the first. Checks the fans tile the rays and their end rays match (O(fans), not O(rays))."""
    start, count = layout.start.astype(np.int64), layout.count.astype(np.int64)
    n = len(o)
    if start.size == 0 or start[0] != 0 or np.any(count < 1) or np.any(start[1:] != start[:-1] + count[:-1]) \
            or int(start[-1] + count[-1]) != n:
        raise _bad(f"{start.size} fans do not cover the {n} rays in order")
    step = np.where(count > 1, layout.step, TWO_PI)  # a one-ray fan: any step > 0 maps its one heading
    if np.any(step <= 0) or np.any((count - 1) * step > TWO_PI + EVEN_TOL):
        raise _bad("every fan needs a heading step > 0 and at most one turn")
    for at, j in ((start, np.zeros_like(count)), (start + count - 1, count - 1)):
        a = layout.heading + j * step
        c, s = np.cos(a), np.sin(a)
        r0, r1 = layout.range_min, layout.range_max
        want_o = np.column_stack([layout.x + r0 * c, layout.y + r0 * s, layout.z])
        want_d = np.column_stack([(r1 - r0) * c, (r1 - r0) * s, np.zeros_like(a)])
        if not (_within(o.take(at, axis=0), want_o) and _within(d.take(at, axis=0), want_d)):
            bad = int(np.flatnonzero(~(np.isclose(o[at], want_o, rtol=0, atol=CHECK_TOL).all(axis=1)
                                       & np.isclose(d[at], want_d, rtol=0, atol=CHECK_TOL).all(axis=1)))[0])
            raise _bad(f"ray {int(at[bad])} is not where fan {bad} puts it")
    reach = float(np.max(layout.range_max - layout.range_min))
    rmin = np.asarray(layout.range_min, np.float64)
    return RayGroups(order=np.arange(n), keys=np.zeros(0), ref=np.asarray(layout.heading, np.float64),
                     centre=np.column_stack([layout.x, layout.y]), spread=rmin, offset=np.zeros(start.size),
                     outward=rmin, reach=max(reach, 0.0), first=start, count=count, step=step)


__all__ = ["RayLayout", "layout_groups"]
