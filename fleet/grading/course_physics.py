"""Physics a grader checks in a robot description: the robot stands on its wheels and caster, and each link's
inertia tensor is near the closed form of its collision shape and mass (a copied `ixx=iyy=izz=1` is not)."""

from __future__ import annotations

from sim.errors import FleetError
from sim.inertia import Inertia, box_inertia, cylinder_inertia, sphere_inertia
from sim.types import Box, Cylinder, Geometry, Sphere
from sim.urdf_model import UrdfRobot

GROUND_TOL = 0.01  # m
INERTIA_FACTOR = 2.0  # principal moments within ×2 of the shape's
FRAME_MASS = 0.01  # kg: lighter links are sensor frames with a token inertial, not bodies


def ground_contact(robot: UrdfRobot, wheels: list[str], casters: list[str]) -> tuple[bool, str]:
    """Standing on its lowest points, do both wheels and a caster touch the ground (within GROUND_TOL)?"""
    lows: dict[str, float] = {}
    for name in robot.links:
        try:
            lows[name] = robot.lowest_point(name)
        except FleetError:  # no primitive collision on this link
            continue
    if not lows or len(wheels) < 2 or not casters:
        return False, "needs two wheels and a caster with box/cylinder/sphere collisions"
    ground = min(lows.values())
    gaps = {n: lows[n] - ground for n in [*wheels, *casters] if n in lows}
    off = {n: g for n, g in gaps.items() if g > GROUND_TOL}
    lowest = min(lows, key=lambda n: lows[n])
    if off or any(w not in gaps for w in wheels) or not any(c in gaps for c in casters):
        what = ", ".join(f"{n} {g * 100:.1f} cm above" for n, g in off.items()) or "missing collisions"
        return False, f"resting on '{lowest}': {what}"
    return True, ", ".join(f"{n} {g * 100:.1f} cm" for n, g in gaps.items())


def _closed_form(mass: float, g: Geometry) -> Inertia | None:
    if isinstance(g, Box):
        return box_inertia(mass, g.size)
    if isinstance(g, Cylinder):
        return cylinder_inertia(mass, g.radius, g.length)
    if isinstance(g, Sphere):
        return sphere_inertia(mass, g.radius)
    return None


def inertia_mismatches(robot: UrdfRobot) -> list[str]:
    """Links whose (physical) tensor's principal moments differ from their one collision shape's by more than
    INERTIA_FACTOR. Invalid tensors are the `inertials` item's; frames and multi-shape links are skipped."""
    out = []
    for link in robot.links.values():
        i = link.inertial
        if i is None or i.mass < FRAME_MASS or not i.inertia.is_physical() or len(link.collisions) != 1:
            continue
        expected = _closed_form(i.mass, link.collisions[0].geometry)
        if expected is None:
            continue
        got, want = i.inertia.principal_moments(), expected.principal_moments()
        ratio = got / want
        if (ratio > INERTIA_FACTOR).any() or (ratio < 1 / INERTIA_FACTOR).any():
            out.append(f"{link.name}: principal moments {', '.join(f'{v:.3g}' for v in got)} vs "
                       f"{', '.join(f'{v:.3g}' for v in want)}")
    return out
