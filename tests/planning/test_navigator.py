"""The navigator on its own (no sim.World): a small accel-limited unicycle and an exact box lidar
stand in for the robot, so these tests pin down plan → track → replan → recover → status."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.controllers.recovery import Recovery
from planning.costmap import LayeredCostmap
from planning.nav_types import NavState
from planning.navigator import Navigator, NavigatorConfig, make_navigator
from sim.drive import integrate_unicycle
from sim.robot_spec import RobotSpec
from sim.types import LidarScan, Pose2D, WorldDescription
from tests.planning.worlds import box, two_rooms, walls

SPEC = RobotSpec()
WorldBoxes = list[tuple[float, float, float, float]]  # axis-aligned obstacles (xmin, ymin, xmax, ymax)


class TinyRobot:
    """Exact unicycle under the robot's acceleration limits, with a 360-beam lidar over axis-aligned boxes."""

    def __init__(self, pose: Pose2D, boxes: WorldBoxes, beams: int = 360) -> None:
        self.pose, self.v, self.w, self.boxes, self.beams = pose, 0.0, 0.0, np.array(boxes), beams
        self.t = 0.0

    def scan(self) -> LidarScan:
        a = -math.pi + 2 * math.pi / self.beams * np.arange(self.beams)
        dx, dy = np.cos(a + self.pose.yaw), np.sin(a + self.pose.yaw)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx0 = (self.boxes[None, :, 0] - self.pose.x) / dx[:, None]
            tx1 = (self.boxes[None, :, 2] - self.pose.x) / dx[:, None]
            ty0 = (self.boxes[None, :, 1] - self.pose.y) / dy[:, None]
            ty1 = (self.boxes[None, :, 3] - self.pose.y) / dy[:, None]
        t_in = np.maximum(np.fmin(tx0, tx1), np.fmin(ty0, ty1))
        t_out = np.minimum(np.fmax(tx0, tx1), np.fmax(ty0, ty1))
        hit = (t_in <= t_out) & (t_in > 0.1) & (t_in <= 10.0)
        ranges = np.where(hit, t_in, np.inf).min(axis=1)
        return LidarScan("r", self.t, -math.pi, 2 * math.pi / self.beams, 0.1, 10.0, ranges)

    def step(self, cmd: tuple[float, float], dt: float) -> None:
        lim = SPEC.limits
        self.v += float(np.clip(cmd[0] - self.v, -lim.max_linear_accel * dt, lim.max_linear_accel * dt))
        self.w += float(np.clip(cmd[1] - self.w, -lim.max_angular_accel * dt, lim.max_angular_accel * dt))
        p = self.pose
        x, y, th = (float(a[0]) for a in integrate_unicycle(
            np.array([p.x]), np.array([p.y]), np.array([p.yaw]), np.array([self.v]), np.array([self.w]), dt))
        self.pose, self.t = Pose2D(x, y, th), self.t + dt

    def clearance(self, boxes: WorldBoxes) -> float:
        """Distance from the robot centre to the nearest box (exact)."""
        b = np.array(boxes)
        dx = np.maximum.reduce([b[:, 0] - self.pose.x, np.zeros(len(b)), self.pose.x - b[:, 2]])
        dy = np.maximum.reduce([b[:, 1] - self.pose.y, np.zeros(len(b)), self.pose.y - b[:, 3]])
        return float(np.hypot(dx, dy).min())


def run(nav: Navigator, robot: TinyRobot, seconds: float, dt: float = 0.05, lidar: bool = True,
        every=None) -> list[float]:
    """Tick at 1/dt until done; returns the robot-centre clearance to the boxes at every step."""
    clearances = []
    for _ in range(int(seconds / dt)):
        cmd = nav.tick(robot.t, robot.pose, (robot.v, robot.w), robot.scan() if lidar else None)
        robot.step(cmd, dt)
        clearances.append(robot.clearance(robot.boxes.tolist()))
        if every is not None:
            every(robot)
        if nav.state.done:
            break
    return clearances


def hall_boxes(xmax: float = 10.0, ymax: float = 6.0, t: float = 0.1) -> WorldBoxes:
    return [(-t, -t, xmax + t, 0.0), (-t, ymax, xmax + t, ymax + t), (-t, -t, 0.0, ymax + t),
            (xmax, -t, xmax + t, ymax + t)]


def navigator(world, controller: str = "mpc_osqp", **kw) -> Navigator:
    costmap = LayeredCostmap.from_world(world, robot_radius=SPEC.footprint_radius, resolution=0.05)
    return make_navigator(NavigatorConfig(controller={"type": controller}, **kw), costmap=costmap, spec=SPEC)


TWO_ROOM_BOXES = [*hall_boxes(), (4.9, 0.0, 5.1, 2.4), (4.9, 3.6, 5.1, 6.0)]  # door 1.2 m at y = 3


@pytest.mark.parametrize("controller", ["mpc_osqp", "mpc_casadi", "pure_pursuit"])
def test_reaches_a_goal_in_the_other_room(controller):
    nav = navigator(two_rooms(), controller)
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)  # pillar and crate are in the map only
    goal = Pose2D(8.5, 4.5, math.pi / 2)
    nav.set_goal(goal, 0.0, align_yaw=True)
    clearances = run(nav, robot, 60.0)
    st = nav.status()
    assert st.state is NavState.SUCCEEDED, st.reason
    assert robot.pose.distance_to(goal) <= 0.15
    assert abs(math.remainder(robot.pose.yaw - goal.yaw, 2 * math.pi)) <= 0.1
    assert min(clearances) > 0.225  # the robot's half width: no wall was touched (and the door is 1.2 m)
    assert st.distance_remaining < 0.3 and st.eta_s == 0.0
    assert st.path_length == pytest.approx(nav.plans[0].length, rel=0.05)  # smoothing only rounds corners


def test_progress_counts_down_and_the_eta_follows():
    nav = navigator(two_rooms())
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    nav.set_goal(Pose2D(8.5, 4.5, 0.0), 0.0)
    assert nav.status(0.0).state is NavState.PLANNING
    seen = []
    run(nav, robot, 60.0, every=lambda r: seen.append(nav.status(r.t)))
    remaining = np.array([s.distance_remaining for s in seen[:-1]])
    assert remaining[0] == pytest.approx(nav.plans[0].length, abs=0.5)
    assert np.all(np.diff(remaining) <= 1e-6)  # never grows on a clear run
    mid = seen[len(seen) // 2]
    assert mid.state is NavState.TRACKING and 0 < mid.eta_s < 2 * mid.distance_remaining / 0.2
    assert seen[-1].to_dict()["state"] == "succeeded"


def test_an_obstacle_missing_from_the_map_is_seen_avoided_and_the_goal_reached():
    world = WorldDescription("hall", models=tuple(walls(0, 0, 10, 6)))
    unknown = (4.6, 1.8, 5.4, 4.2)  # a 0.8 × 2.4 m crate on the straight line y = 3
    robot = TinyRobot(Pose2D(1.0, 3.0, 0.0), [*hall_boxes(), unknown])
    nav = navigator(world)
    nav.set_goal(Pose2D(9.0, 3.0, 0.0), 0.0)
    clearances = run(nav, robot, 60.0)
    st = nav.status()
    assert st.state is NavState.SUCCEEDED, st.reason
    assert st.replans >= 1  # blocked by the crate, it planned around it
    assert min(clearances) > 0.25  # never touched it (front half-length 0.25 m)


def test_a_goal_inside_a_wall_fails_at_once_with_the_reason():
    nav = navigator(two_rooms())
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    nav.set_goal(Pose2D(5.0, 1.0, 0.0), 0.0)  # inside the divider
    run(nav, robot, 5.0)
    st = nav.status()
    assert st.state is NavState.FAILED and "in collision" in st.reason and st.recoveries == 0


def test_an_enclosed_goal_fails_after_the_recoveries():
    pen = [box("pen_s", 7.5, 1.0, 2.0, 0.2), box("pen_n", 7.5, 3.0, 2.0, 0.2), box("pen_w", 6.5, 2.0, 0.2, 2.2),
           box("pen_e", 8.5, 2.0, 0.2, 2.2)]
    world = WorldDescription("pen", models=(*walls(0, 0, 10, 6), *pen))
    nav = navigator(world, max_recoveries=2)
    robot = TinyRobot(Pose2D(2.0, 4.0, 0.0), hall_boxes())
    nav.set_goal(Pose2D(7.5, 2.0, 0.0), 0.0)
    run(nav, robot, 60.0)
    st = nav.status()
    assert st.state is NavState.FAILED and "enclosed" in st.reason and st.recoveries == 2


def test_cancel_stops_the_robot():
    nav = navigator(two_rooms())
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    nav.set_goal(Pose2D(8.5, 4.5, 0.0), 0.0)
    run(nav, robot, 3.0)
    nav.cancel()
    assert nav.status().state is NavState.CANCELED
    assert nav.tick(robot.t, robot.pose, (robot.v, robot.w), None) == (0.0, 0.0)


def test_pushed_off_the_path_it_replans_and_still_arrives():
    nav = navigator(two_rooms(), off_path_distance=0.4)
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    nav.set_goal(Pose2D(8.5, 4.5, 0.0), 0.0)
    run(nav, robot, 2.5)
    robot.pose = Pose2D(robot.pose.x, robot.pose.y + 1.0, robot.pose.yaw)  # kidnapped 1 m sideways
    run(nav, robot, 60.0)
    st = nav.status()
    assert st.state is NavState.SUCCEEDED and st.replans >= 1


def test_recovery_backs_up_then_spins_by_the_configured_amounts():
    rec = Recovery(backup_distance=0.3, backup_speed=0.15, spin_angle=math.pi / 2, spin_speed=1.0)
    costmap = LayeredCostmap.from_world(two_rooms(), robot_radius=0.3)
    assert rec.begin(3, costmap) == ["clear_costmap", "backup", "spin"]
    robot = TinyRobot(Pose2D(2.0, 3.0, 0.0), [])
    start = robot.pose
    while (cmd := rec.step(robot.t, robot.pose)) is not None:
        robot.step(cmd, 0.02)
    turned = math.remainder(robot.pose.yaw - start.yaw, 2 * math.pi)
    assert robot.pose.x < start.x and robot.pose.distance_to(start) == pytest.approx(0.3, abs=0.03)
    assert turned == pytest.approx(math.pi / 2, abs=0.12)  # stops commanding at π/2; inertia adds a little


def test_a_path_behind_the_robot_is_started_by_turning_on_the_spot():
    nav = navigator(two_rooms(), rotate_to_heading_angle=0.8)
    robot = TinyRobot(Pose2D(2.0, 1.5, 0.0), TWO_ROOM_BOXES)
    nav.set_goal(Pose2D(0.8, 1.5, 0.0), 0.0)  # straight behind
    poses = []
    run(nav, robot, 20.0, every=lambda r: poses.append(r.pose))
    assert nav.status().state is NavState.SUCCEEDED
    turning = [p for p in poses if abs(math.remainder(p.yaw - math.pi, 2 * math.pi)) > 0.2]
    assert turning and max(p.distance_to(Pose2D(2.0, 1.5)) for p in turning) < 0.02  # turned in place first
