"""PyBullet bodies for robots: a one-body proxy for kinematic robots, the generated URDF for dynamic ones."""

from __future__ import annotations

import hashlib
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import pybullet as p

from sim.errors import ErrorCode, FleetError
from sim.robot_spec import RobotSpec

GROUND_GROUP = 4  # collision group of ground planes: kinematic proxies never test against them
ALL_BUT_GROUND = 0xFFFF & ~GROUND_GROUP


@dataclass
class RobotBody:
    uid: int
    link_names: dict[int, str] = field(default_factory=dict)  # -1 is the base
    left_wheel: int = -1
    right_wheel: int = -1
    drive_left: list[int] = field(default_factory=list)  # every driven joint (4-wheel bases drive two pairs)
    drive_right: list[int] = field(default_factory=list)


def kinematic_proxy(client: int, spec: RobotSpec) -> RobotBody:
    """Chassis+wheels envelope box, mast and lidar housing as one compound body (cheap to teleport and test).

    Its base frame is base_link on the floor under the axle centre; mass > 0 so Bullet tests it against
    static obstacles, and it never sleeps so contacts are always computed. A robot from a URDF gets its own
    collision primitives instead (sim.urdf_proxy)."""
    if spec.description is not None:
        from sim.urdf_proxy import urdf_proxy

        return RobotBody(urdf_proxy(client, spec), {-1: "base_link"})
    hx = spec.chassis.size[0] / 2
    hy = max(spec.chassis.size[1] / 2, spec.wheels.separation / 2 + spec.wheels.width / 2)
    top = spec.chassis_z + spec.chassis.size[2] / 2
    bottom = 0.02
    mast_top = top + spec.mast.height
    housing_r = max(0.05, spec.mast.radius)
    shapes = [
        (p.GEOM_BOX, [hx, hy, (top - bottom) / 2], 0.0, 0.0, [0, 0, (top + bottom) / 2]),
        (p.GEOM_CYLINDER, None, spec.mast.radius, spec.mast.height,
         [spec.mast.x_offset, 0, top + spec.mast.height / 2]),
        (p.GEOM_CYLINDER, None, housing_r, 0.06, [spec.mast.x_offset, 0, mast_top + 0.03]),
    ]
    kw = dict(shapeTypes=[s[0] for s in shapes], halfExtents=[s[1] or [0, 0, 0] for s in shapes],
              radii=[s[2] for s in shapes], lengths=[s[3] for s in shapes],
              collisionFramePositions=[s[4] for s in shapes], physicsClientId=client)
    col = p.createCollisionShapeArray(**kw)
    rgba = list(spec.chassis.rgba)
    vis = p.createVisualShapeArray(shapeTypes=kw["shapeTypes"], halfExtents=kw["halfExtents"], radii=kw["radii"],
                                   lengths=kw["lengths"], visualFramePositions=kw["collisionFramePositions"],
                                   rgbaColors=[rgba, [0.2, 0.2, 0.2, 1], [0.1, 0.1, 0.1, 1]],
                                   physicsClientId=client)
    uid = p.createMultiBody(baseMass=spec.total_mass, baseCollisionShapeIndex=col, baseVisualShapeIndex=vis,
                            basePosition=[0, 0, 0], physicsClientId=client)
    p.changeDynamics(uid, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client)
    p.setCollisionFilterGroupMask(uid, -1, 1, ALL_BUT_GROUND, physicsClientId=client)
    return RobotBody(uid, {-1: "base_link"})


_URDF_CACHE: dict[str, Path] = {}


def _urdf_file(spec: RobotSpec) -> Path:
    from sim.urdf import robot_urdf  # generated from the one spec (sim/urdf.py)

    text = robot_urdf(spec)
    key = hashlib.sha1(text.encode()).hexdigest()[:16]
    if key not in _URDF_CACHE or not _URDF_CACHE[key].exists():
        path = Path(tempfile.gettempdir()) / f"fleetnav_{spec.name}_{key}.urdf"
        path.write_text(text, encoding="utf-8")
        _URDF_CACHE[key] = path
    return _URDF_CACHE[key]


def dynamic_robot(client: int, spec: RobotSpec) -> RobotBody:
    """The full URDF robot (the user's description, or the one generated from the spec) with its driven wheel
    joints under velocity motors."""
    path = spec.description or str(_urdf_file(spec))
    uid = p.loadURDF(path, [0, 0, 0], useFixedBase=False,
                     flags=p.URDF_USE_INERTIA_FROM_FILE | p.URDF_USE_IMPLICIT_CYLINDER, physicsClientId=client)
    body = RobotBody(uid, {-1: p.getBodyInfo(uid, physicsClientId=client)[0].decode()})
    left, right = spec.wheels.left_joints, spec.wheels.right_joints
    for j in range(p.getNumJoints(uid, physicsClientId=client)):
        info = p.getJointInfo(uid, j, physicsClientId=client)
        jname, lname = info[1].decode(), info[12].decode()
        body.link_names[j] = lname
        if jname in left:
            body.drive_left.append(j)
        elif jname in right:
            body.drive_right.append(j)
        # Free-spinning passive joints (caster): disable the default motor that would brake them.
        elif info[2] == p.JOINT_REVOLUTE:
            p.setJointMotorControl2(uid, j, p.VELOCITY_CONTROL, force=0, physicsClientId=client)
    if len(body.drive_left) != len(left) or len(body.drive_right) != len(right):
        p.removeBody(uid, physicsClientId=client)
        raise FleetError(ErrorCode.INVALID_CONFIG, f"robot '{spec.name}': {path} lacks the wheel joints "
                         f"{', '.join((*left, *right))}", "name the driven joints in wheels.left_joints/right_joints")
    body.left_wheel, body.right_wheel = body.drive_left[0], body.drive_right[0]
    p.changeDynamics(uid, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client)
    return body
