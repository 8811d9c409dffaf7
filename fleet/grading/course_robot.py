"""`fleetnav check robot`: grade a URDF against the course's "Robot Model" (25 pts) and "Gazebo Plugins
Integration" (20 pts) requirements, as a grader reading the file would: the physics must hold together
(course_physics.py) and the plugins must agree with the geometry (course_plugins.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fleet.grading.course_physics import GROUND_TOL, INERTIA_FACTOR, ground_contact, inertia_mismatches
from fleet.grading.course_plugins import add_plugin_items
from fleet.grading.rubric import RubricReport
from sim.types import Box, Cylinder, Sphere
from sim.urdf_model import UrdfRobot, UrdfSensor
from sim.urdf_parser import parse_urdf
from sim.urdf_robot import read_description

REL_TOL = 0.05  # dimensions within 5 %
MASS = 5.0
MASS_TOL = 0.5  # kg: "~5 kg"


def _close(a: float, b: float, rel: float = REL_TOL) -> bool:
    return abs(a - b) <= rel * abs(b)


def _wheel_joints(robot: UrdfRobot) -> list[str]:
    return [j.name for j in robot.joints.values() if j.type == "continuous" and "wheel" in j.child.lower()]


def _sensor(robot: UrdfRobot, *types: str) -> UrdfSensor | None:
    return next((s for s in robot.sensors if s.type in types), None)


def check_robot(path: str | Path) -> RubricReport:
    """Grade a .urdf or .urdf.xacro file (xacro is expanded first)."""
    text, name, base_dir = read_description(Path(path))
    return grade_robot(parse_urdf(text, name=name, base_dir=base_dir), str(path))


def grade_robot(robot: UrdfRobot, source: str) -> RubricReport:
    rep = RubricReport(f"Robot Model + Gazebo Plugins ({Path(source).name})", source)
    wheels = _wheel_joints(robot)
    casters = [lk for lk in robot.links.values() if "caster" in lk.name.lower()
               or any(isinstance(c.geometry, Sphere) for c in lk.collisions)]
    rep.add("diff_drive", "differential drive base: 2 wheels + 1 caster", 3, len(wheels) == 2 and len(casters) >= 1,
            f"{len(wheels)} wheel joints ({', '.join(wheels)}), {len(casters)} caster(s)", "2 + 1")

    boxes = [(lk.name, c.geometry) for lk in robot.links.values() for c in lk.collisions
             if isinstance(c.geometry, Box)]
    chassis = max(boxes, key=lambda b: float(np.prod(b[1].size)), default=None)
    dims = tuple(sorted(chassis[1].size, reverse=True)) if chassis else ()
    rep.add("chassis", "chassis 0.5 × 0.4 × 0.2 m", 3,
            bool(dims) and all(_close(a, b) for a, b in zip(dims, (0.5, 0.4, 0.2), strict=True)),
            " × ".join(f"{d:.3f}" for d in dims) or "no box link", "0.5 × 0.4 × 0.2 (±5 %)")

    radii = [c.geometry.radius for j in wheels for c in robot.links[robot.joints[j].child].collisions
             if isinstance(c.geometry, Cylinder)]
    rep.add("wheel_radius", "wheels of 0.1 m radius", 2, len(radii) == 2 and all(_close(r, 0.1) for r in radii),
            ", ".join(f"{r:.3f}" for r in radii) or "no wheel cylinders", "0.1 m")

    sep = robot.wheel_separation(*wheels) if len(wheels) == 2 else math.nan
    rep.add("wheel_separation", "wheel separation 0.4 m", 2, _close(sep, 0.4), f"{sep:.3f} m", "0.4 m")

    masts = [c.geometry.length if isinstance(c.geometry, Cylinder) else c.geometry.size[2]
             for lk in robot.links.values() if "mast" in lk.name.lower() for c in lk.collisions
             if isinstance(c.geometry, Cylinder | Box)]
    mast_h = max(masts, default=math.nan)
    rep.add("mast", "sensor mast 0.3 m tall", 2, _close(mast_h, 0.3), f"{mast_h:.3f} m", "0.3 m")

    mass = robot.total_mass()
    rep.add("mass", "total mass ≈ 5 kg", 2, abs(mass - MASS) <= MASS_TOL, f"{mass:.3f} kg", f"{MASS} ± {MASS_TOL} kg")

    no_inertial = [lk.name for lk in robot.links.values() if lk.inertial is None or lk.inertial.mass <= 0
                   or not lk.inertial.inertia.is_physical()]
    rep.add("inertials", "inertial properties on all links, physically valid", 1, not no_inertial,
            "all links" if not no_inertial else f"missing/invalid on {', '.join(no_inertial)}",
            "every link: mass > 0, tensor positive definite, I1 + I2 ≥ I3")
    far = inertia_mismatches(robot)
    rep.add("inertia_geometry", "inertia tensors near their geometry's", 1, not far,
            "all within ×2" if not far else "; ".join(far), f"principal moments within ×{INERTIA_FACTOR:g} of the "
            "collision shape's closed form")

    friction_links = [*[robot.joints[j].child for j in wheels], *[c.name for c in casters]]
    def has_friction(name: str) -> bool:
        link = robot.links[name]
        return (link.contact is not None and link.contact.lateral is not None) or "mu1" in link.gazebo

    unfrictioned = [n for n in friction_links if not has_friction(n)]
    rep.add("friction", "friction coefficients on wheels and caster", 2, bool(friction_links) and not unfrictioned,
            "all set" if not unfrictioned else f"missing on {', '.join(unfrictioned)}", "wheels and caster")

    mismatched = [lk.name for lk in robot.links.values()
                  if [(v.geometry, v.origin) for v in lk.visuals] != [(c.geometry, c.origin) for c in lk.collisions]
                  and (lk.visuals or lk.collisions)]
    rep.add("collision_matches_visual", "collision geometries match visual", 1, not mismatched,
            "all links" if not mismatched else f"differ on {', '.join(mismatched)}", "identical geometry and origin")
    contact_ok, contact = ground_contact(robot, [robot.joints[j].child for j in wheels], [c.name for c in casters])
    rep.add("ground_contact", "wheels rest on the ground plane, the caster touches it", 1, contact_ok, contact,
            f"wheels and caster within {GROUND_TOL * 100:g} cm of the lowest point")

    lidar = _sensor(robot, "ray", "gpu_ray", "gpu_lidar", "lidar")
    if lidar is not None and lidar.min_angle is not None and lidar.max_angle is not None and lidar.samples:
        # Gazebo spaces `samples` rays evenly from min to max angle inclusive.
        res = math.degrees(lidar.max_angle - lidar.min_angle) / max(1, lidar.samples - 1)
        fov = res * lidar.samples
        ok = (fov >= 359.0 and _close(res, 1.0, 0.02) and _close(lidar.range_min or 0, 0.1)
              and _close(lidar.range_max or 0, 10.0) and _close(lidar.update_rate or 0, 10.0))
        measured = (f"{fov:.0f}°, {res:.2f}°/beam, {lidar.range_min}–{lidar.range_max} m, "
                    f"{lidar.update_rate} Hz")
    else:
        ok, measured = False, "no ray sensor"
    rep.add("lidar", "LIDAR 360°, 0.1–10 m, 1° resolution, 10 Hz", 2, ok, measured, "360°, 0.1–10 m, 1°, 10 Hz")

    cam = next((s for s in robot.sensors if s.type == "camera"), None)
    if cam is not None:
        fov = math.degrees(cam.horizontal_fov or 0)
        ok = (cam.image_width == 640 and cam.image_height == 480 and _close(fov, 60.0, 0.02)
              and _close(cam.update_rate or 0, 30.0))
        measured = f"{cam.image_width}×{cam.image_height}, {fov:.1f}°, {cam.update_rate} Hz"
    else:
        ok, measured = False, "no camera sensor"
    rep.add("camera", "RGB camera 640×480, 60° FOV, 30 Hz", 2, ok, measured, "640×480, 60°, 30 Hz")

    imu = _sensor(robot, "imu")
    rep.add("imu", "IMU at 100 Hz", 1, imu is not None and _close(imu.update_rate or 0, 100.0),
            f"{imu.update_rate} Hz" if imu else "no imu sensor", "100 Hz")
    add_plugin_items(rep, robot, wheels)
    depth = _sensor(robot, "depth")
    rep.notes.append("depth camera (optional): " + (f"{depth.image_width}×{depth.image_height}, "
                                                      f"{depth.range_min}–{depth.range_max} m" if depth else "absent"))
    return rep
