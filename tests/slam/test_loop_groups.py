"""Loop groups (slam/loop_groups.py) and the edge a group names (slam/edge_switch.py), on a synthetic graph:
a square route of 1 m steps whose front end took a wrong corridor peak at one step (2 m short), then a return
past the start. Each true loop closure alone contradicts the graph and is rejected; together they agree, name
the wrong step (its score surface has a peak where they want it and the moved step matches the previous one),
and the trajectory comes back to the truth."""

from __future__ import annotations

import math

import numpy as np

from sim.transforms import se2_between, se2_compose
from slam import se2
from slam.edge_switch import EdgeSwitchConfig, Surface, rank_edges
from slam.log_slam import LogSlam
from slam.loop_groups import LoopGroupConfig, Pending, consistent, largest_group

WRONG = 15  # the step matched 2 m short


def _truth(n: int = 48) -> list[se2.PoseTuple]:
    poses: list[se2.PoseTuple] = [(0.0, 0.0, 0.0)]
    for k in range(1, n):
        turn = math.pi / 2 if k % 10 == 0 else 0.0  # a 10 m square
        poses.append(se2_compose(poses[-1], (1.0, 0.0, turn)))
    return poses


def _surface(peak_at: tuple[float, float] | None) -> Surface:
    g = np.arange(-16, 17) * 0.15
    gx, gy = np.meshgrid(g, g, indexing="ij")
    offs = np.column_stack([gx.ravel(), gy.ravel()])
    drop = np.full(len(offs), -0.5)
    drop[np.argmin(np.hypot(offs[:, 0], offs[:, 1]))] = 0.0
    if peak_at is not None:
        drop[np.argmin(np.hypot(offs[:, 0] - peak_at[0], offs[:, 1] - peak_at[1]))] = -0.03
    return Surface(offs, drop)


def _slam_with_wrong_step(truth: list[se2.PoseTuple]) -> LogSlam:
    slam = LogSlam()
    cov = np.diag([1e-4, 1e-4, 1e-5])
    pose = truth[0]
    slam.graph.add_pose(pose)
    slam._append(0.0, pose, np.zeros((0, 2)), np.zeros(0), None, 0.0)
    for k in range(1, len(truth)):
        rel = se2_between(truth[k - 1], truth[k])
        if k == WRONG:
            rel = (rel[0] - 2.0, rel[1], rel[2])  # the corridor peak behind the truth
        pose = se2_compose(pose, rel)
        slam.graph.add_pose(pose, rel, cov)
        slam.edges.append((k - 1, k, rel, cov))
        slam._append(float(k), pose, np.zeros((0, 2)), np.zeros(0), None, slam.path[-1] + math.hypot(*rel[:2]))
        slam.surfaces[k] = _surface((2.0, 0.0) if k == WRONG else None)
    slam.graph.update()
    slam.refresh_poses()
    return slam


def test_pairwise_consistency_ignores_a_wrong_stretch_and_rejects_a_wrong_closure() -> None:
    truth = _truth()
    slam = _slam_with_wrong_step(truth)
    cov = np.diag([1e-3, 1e-3, 1e-4])
    pairs = ((1, 41), (2, 42), (3, 43))
    right = [Pending(t, s, se2_between(truth[t], truth[s]), cov, 0.8, 0.9, 0.02) for t, s in pairs]
    wrong = Pending(2, 44, se2_compose(se2_between(truth[2], truth[44]), (0.0, 0.8, 0.0)), cov, 0.6, 0.7, 0.04)
    cfg = LoopGroupConfig()
    # the estimate is 2 m off between target and source, but the stretches between the ends are right
    assert consistent(right[0], right[1], slam.poses, slam.path, cfg)
    assert not consistent(right[0], wrong, slam.poses, slam.path, cfg)
    assert largest_group([*right, wrong], 3, slam.poses, slam.path, cfg) == [3]
    assert sorted(largest_group([*right, wrong], 0, slam.poses, slam.path, cfg)) == [0, 1, 2]


def test_rank_edges_names_the_step_whose_surface_and_motion_support_the_move() -> None:
    truth = _truth()
    slam = _slam_with_wrong_step(truth)
    yaw = slam.poses[WRONG][2]  # the path after the wrong step must move 2 m along its heading
    d = 2.0 * np.array([math.cos(yaw), math.sin(yaw)])
    ranked = rank_edges(list(range(5, 41)), slam.surfaces, slam.poses, d, EdgeSwitchConfig())
    assert ranked[0][0] == WRONG
    assert all(e == WRONG for e, _ in ranked)  # every other surface drops by 0.5 there


def test_a_group_of_true_loops_moves_the_wrong_step_and_restores_the_trajectory() -> None:
    truth = _truth()
    slam = _slam_with_wrong_step(truth)
    err0 = max(math.hypot(p[0] - t[0], p[1] - t[1]) for p, t in zip(slam.poses, truth, strict=True))
    assert err0 > 1.9
    cov = np.diag([9e-4, 9e-4, 1e-4])
    results = [slam.loops.add(t, s, se2_between(truth[t], truth[s]), cov) for t, s in ((1, 41), (2, 42), (3, 43))]
    assert not any(c.accepted for c in results)  # alone, each contradicts the graph
    assert slam.loops.switched == [WRONG]
    assert slam.loops.accepted == 3
    assert slam.loops.reasons["accepted_in_group"] == 3
    err = max(math.hypot(p[0] - t[0], p[1] - t[1]) for p, t in zip(slam.poses, truth, strict=True))
    assert err < 0.05
