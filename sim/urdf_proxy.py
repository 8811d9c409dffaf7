"""The kinematic body of a robot loaded from a URDF: its collision shapes at zero joint angles, as one compound
body whose frame is base_link (cheap to teleport and test, like sim.robot_body.kinematic_proxy)."""

from __future__ import annotations

from functools import cache
from typing import Any

import pybullet as p

from sim.robot_spec import RobotSpec
from sim.types import Box, Cylinder, Mesh, Pose3D, Sphere
from sim.urdf_model import UrdfRobot
from sim.urdf_parser import parse_urdf

GROUND_GROUP = 4  # as sim.robot_body: kinematic robots never test against ground planes
ALL_BUT_GROUND = 0xFFFF & ~GROUND_GROUP


@cache
def proxy_shapes(path: str) -> list[tuple[Any, Pose3D]]:
    """(geometry, pose in base_link) of every collision shape; the root of `path` is base_link. The file is
    named by its content's hash (sim.urdf_process), so caching by path is safe."""
    robot: UrdfRobot = parse_urdf(path)
    return [(c.geometry, pose.compose(c.origin)) for link, pose in robot.link_poses().items()
            for c in robot.links[link].collisions]


def urdf_proxy(client: int, spec: RobotSpec) -> int:
    assert spec.description is not None
    types, half, radii, lengths, files, scales, pos, orn = [], [], [], [], [], [], [], []
    for g, pose in proxy_shapes(spec.description):
        kind, h, r, length, f, s = p.GEOM_BOX, [0.0] * 3, 0.0, 0.0, "", [1.0] * 3
        if isinstance(g, Box):
            h = [v / 2 for v in g.size]
        elif isinstance(g, Cylinder):
            kind, r, length = p.GEOM_CYLINDER, g.radius, g.length
        elif isinstance(g, Sphere):
            kind, r = p.GEOM_SPHERE, g.radius
        elif isinstance(g, Mesh):
            kind, f, s = p.GEOM_MESH, g.path, list(g.scale)
        else:
            continue
        types.append(kind)
        half.append(h)
        radii.append(r)
        lengths.append(length)
        files.append(f)
        scales.append(s)
        pos.append(list(pose.position))
        orn.append(list(pose.quaternion))
    kw: dict[str, Any] = dict(shapeTypes=types, halfExtents=half, radii=radii, lengths=lengths,
                              collisionFramePositions=pos, collisionFrameOrientations=orn, physicsClientId=client)
    if any(files):
        kw |= dict(fileNames=files, meshScales=scales)
    col = p.createCollisionShapeArray(**kw)
    vis_kw = {k: v for k, v in kw.items() if k not in ("collisionFramePositions", "collisionFrameOrientations")}
    vis = p.createVisualShapeArray(**vis_kw, visualFramePositions=pos, visualFrameOrientations=orn,
                                   rgbaColors=[list(spec.chassis.rgba)] * len(types))
    uid = p.createMultiBody(baseMass=spec.total_mass, baseCollisionShapeIndex=col, baseVisualShapeIndex=vis,
                            basePosition=[0, 0, 0], physicsClientId=client)
    p.changeDynamics(uid, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client)
    p.setCollisionFilterGroupMask(uid, -1, 1, ALL_BUT_GROUND, physicsClientId=client)
    return int(uid)
