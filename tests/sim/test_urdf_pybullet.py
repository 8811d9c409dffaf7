"""The generated URDF in a real PyBullet DIRECT client: structure, masses, friction, and physics that
holds still at rest and rolls at ω·r when driven."""

import math
from collections.abc import Iterator

import pybullet as p
import pytest

from sim.robot_spec import default_robot_path, load_robot_spec
from sim.urdf import write_robot_urdf
from sim.urdf_parser import parse_urdf

HZ = 240
LOAD = p.URDF_USE_INERTIA_FROM_FILE  # what sim.robot_body.dynamic_robot passes
SMOOTH = LOAD | p.URDF_USE_IMPLICIT_CYLINDER  # exact cylinders instead of a faceted hull


@pytest.fixture(scope="module")
def urdf_path(tmp_path_factory):
    return write_robot_urdf(load_robot_spec(default_robot_path()), tmp_path_factory.mktemp("urdf") / "r.urdf")


@pytest.fixture
def client() -> Iterator[int]:
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    p.setTimeStep(1 / HZ, physicsClientId=cid)
    p.createMultiBody(0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=cid), physicsClientId=cid)
    yield cid
    p.disconnect(cid)


def _load(cid: int, path, flags: int) -> tuple[int, dict[str, int]]:
    uid = p.loadURDF(str(path), [0, 0, 0], flags=flags, physicsClientId=cid)
    joints = {p.getJointInfo(uid, j, physicsClientId=cid)[1].decode(): j
              for j in range(p.getNumJoints(uid, physicsClientId=cid))}
    return uid, joints


def _link_index(cid: int, uid: int, name: str) -> int:
    return next(j for j in range(p.getNumJoints(uid, physicsClientId=cid))
                if p.getJointInfo(uid, j, physicsClientId=cid)[12].decode() == name)


def test_pybullet_sees_every_joint_and_the_total_mass(client, urdf_path):
    robot = parse_urdf(urdf_path)
    uid, joints = _load(client, urdf_path, LOAD)
    assert p.getBodyInfo(uid, physicsClientId=client)[0].decode() == robot.root == "base_link"
    assert set(joints) == set(robot.joints) and len(joints) == len(robot.links) - 1 == 11
    masses = [p.getDynamicsInfo(uid, j, physicsClientId=client)[0] for j in range(-1, len(joints))]
    assert sum(masses) == pytest.approx(robot.total_mass())
    assert sum(masses) == pytest.approx(5.0, abs=0.1)
    revolute = [n for n, j in joints.items() if p.getJointInfo(uid, j, physicsClientId=client)[2] == p.JOINT_REVOLUTE]
    assert sorted(revolute) == ["left_wheel_joint", "right_wheel_joint"]


def test_pybullet_reads_the_inertia_and_contact_friction(client, urdf_path):
    uid, _ = _load(client, urdf_path, LOAD)
    wheel = p.getDynamicsInfo(uid, _link_index(client, uid, "left_wheel_link"), physicsClientId=client)
    assert wheel[2] == pytest.approx((0.5 * (3 * 0.01 + 0.0025) / 12, 0.0025, 0.5 * (3 * 0.01 + 0.0025) / 12))
    assert (wheel[1], wheel[6], wheel[7]) == pytest.approx((1.0, 0.001, 0.001))  # lateral, rolling, spinning
    caster = p.getDynamicsInfo(uid, _link_index(client, uid, "caster_link"), physicsClientId=client)
    assert caster[1] == pytest.approx(0.01)


def test_base_pose_is_base_link_on_the_floor(client, urdf_path):
    """The root's inertial is at its origin, so PyBullet's body pose is base_link itself, not a COM."""
    uid, _ = _load(client, urdf_path, LOAD)
    pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    assert pos == pytest.approx((0.0, 0.0, 0.0)) and orn == pytest.approx((0.0, 0.0, 0.0, 1.0))
    chassis = p.getLinkState(uid, _link_index(client, uid, "chassis_link"), physicsClientId=client)
    assert chassis[4] == pytest.approx((0.0, 0.0, 0.15))  # link frame at chassis_z


@pytest.mark.parametrize("flags", [LOAD, SMOOTH], ids=["hull_cylinders", "implicit_cylinders"])
def test_robot_resting_on_a_plane_stays_put_for_two_seconds(client, urdf_path, flags):
    uid, _ = _load(client, urdf_path, flags)
    for _ in range(2 * HZ):
        p.stepSimulation(physicsClientId=client)
    pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    lin, ang = p.getBaseVelocity(uid, physicsClientId=client)
    roll, pitch, _ = p.getEulerFromQuaternion(orn)
    assert math.hypot(pos[0], pos[1]) < 2e-3 and abs(pos[2]) < 2e-3  # m: settles, no drift, no explosion
    assert abs(roll) < 0.01 and abs(pitch) < 0.01  # rad
    assert math.hypot(*lin) < 1e-3 and math.hypot(*ang) < 1e-2


def _drive(cid: int, path, left: float, right: float) -> tuple[int, tuple, tuple]:
    """Run the wheels at (ωl, ωr) rad/s for 2 s; return the body and its final linear/angular velocity."""
    uid, joints = _load(cid, path, SMOOTH)
    for name, rate in (("left_wheel_joint", left), ("right_wheel_joint", right)):
        p.setJointMotorControl2(uid, joints[name], p.VELOCITY_CONTROL, targetVelocity=rate, force=10.0,
                                physicsClientId=cid)
    for _ in range(2 * HZ):
        p.stepSimulation(physicsClientId=cid)
    lin, ang = p.getBaseVelocity(uid, physicsClientId=cid)
    return uid, lin, ang


R, S, WIDTH = 0.1, 0.4, 0.05


def test_equal_wheel_rates_drive_straight_at_omega_r(client, urdf_path):
    _, lin, ang = _drive(client, urdf_path, 5.0, 5.0)
    assert lin[0] == pytest.approx(R * 5.0, abs=0.005)  # v = r·ω = 0.5 m/s along +x (forward)
    assert abs(lin[1]) < 1e-3 and abs(ang[2]) < 1e-2


def test_opposite_wheel_rates_spin_at_the_unicycle_yaw_rate(client, urdf_path):
    """ω = r(ωr − ωl)/s = 2 rad/s. Bullet's cylinder–plane contact is one point on an edge of the tread,
    so the spin centre can sit up to width/2 off the axle centre: base_link circles within 2.5 cm."""
    uid, lin, ang = _drive(client, urdf_path, -4.0, 4.0)
    assert ang[2] == pytest.approx(R * 8.0 / S, abs=0.02)
    pos, _ = p.getBasePositionAndOrientation(uid, physicsClientId=client)
    assert math.hypot(pos[0], pos[1]) <= WIDTH + 1e-3  # a circle of radius ≤ width/2 about a point ≤ width/2 away
    assert math.hypot(lin[0], lin[1]) <= ang[2] * WIDTH / 2 + 5e-3
