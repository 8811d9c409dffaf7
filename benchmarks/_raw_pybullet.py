"""Raw PyBullet doing the same work as the World, step by step, on a twin client holding the same scene.

The twin is built from the same SDF and robot spec (so its bodies are the World's bodies, uid for uid) and
then only ever driven by raw PyBullet calls, never by World.step. One raw step runs right after each of our
steps, so a change in load on this shared machine hits both sides alike. Each raw step makes only the calls
the work needs, with every Python list built before its clock starts: it is the engine's limit. The
benchmark is the one place outside sim/ that imports pybullet, and only for these baselines.
"""

from __future__ import annotations

import time

import numpy as np
import pybullet as p
from scipy.spatial import cKDTree

from sim import World
from sim.kinematic_collisions import PENETRATION
from sim.sensors.lidar import LidarConfig

MAX_RAYS_PER_CALL = 16_000  # as the World: exactly 16,384 rays returns an empty list


class RawBaseline:
    """Raw steps on `twin` (a World built like ours, never stepped); each returns its PyBullet seconds."""

    def __init__(self, twin: World) -> None:
        self.client = c = twin.client
        names = twin.robot_names()
        self.uids = [twin.bodies[n].uid for n in names]
        specs = [twin.robot_spec(n) for n in names]
        self.radius = max(s.footprint_radius for s in specs)
        self.lidar = LidarConfig.from_spec(specs[0]) if specs[0].sensors.lidar.enabled else None
        self.wheels = [[twin.bodies[n].left_wheel, twin.bodies[n].right_wheel] for n in names]
        self.wheel_geom = np.array([(s.wheels.radius, s.wheels.separation, s.wheels.max_torque) for s in specs])
        robots = set(self.uids)
        every = [p.getBodyUniqueId(k, physicsClientId=self.client) for k in range(p.getNumBodies(physicsClientId=c))]
        statics = [u for u in every if u not in robots and u not in twin.models.ground_uids()]
        self.static_uids = np.array(statics, dtype=np.int64)
        aabbs = [p.getAABB(u, physicsClientId=self.client) for u in statics]
        self.static_lo = np.array([a[0][:2] for a in aabbs]).reshape(-1, 2)
        self.static_hi = np.array([a[1][:2] for a in aabbs]).reshape(-1, 2)
        self.cpu_s = 0.0  # process CPU time of the timed motion steps (kinematic and dynamic), summed

    def kinematic_step(self, pose: np.ndarray) -> float:
        """Teleport every robot to `pose` ((n, 3): x, y, yaw) with resetBasePositionAndOrientation, then
        performCollisionDetection and getContactPoints: detection only, nothing resolved."""
        c = self.client
        positions = [(x, y, 0.0) for x, y in pose[:, :2].tolist()]
        half = pose[:, 2] / 2
        quats = [(0.0, 0.0, s, w) for s, w in zip(np.sin(half).tolist(), np.cos(half).tolist(), strict=True)]
        c0, t0 = time.process_time(), time.perf_counter()  # the CPU clock read outside the wall window
        for uid, pos, orn in zip(self.uids, positions, quats, strict=True):
            p.resetBasePositionAndOrientation(uid, pos, orn, physicsClientId=c)
        p.performCollisionDetection(physicsClientId=c)
        p.getContactPoints(physicsClientId=c)
        wall = time.perf_counter() - t0
        self.cpu_s += time.process_time() - c0
        return wall

    def penetrating_pairs(self, pose: np.ndarray) -> int:
        """Pairs (robot–robot, robot–obstacle) deeper in each other than the World tolerates at the pose of
        the last kinematic_step, each measured afresh with getClosestPoints (contact manifolds cached from
        earlier steps play no part). Candidates come from footprint circles and obstacle AABBs."""
        c, r = self.client, self.radius
        pairs = [(self.uids[i], self.uids[j]) for i, j in cKDTree(pose[:, :2]).query_pairs(2 * r)]
        xy = pose[:, None, :2]
        near = np.all((xy + r >= self.static_lo[None]) & (xy - r <= self.static_hi[None]), axis=2)
        pairs += [(self.uids[i], int(self.static_uids[k])) for i, k in zip(*np.nonzero(near), strict=True)]
        return sum(min((pt[8] for pt in p.getClosestPoints(a, b, 0.0, physicsClientId=c)), default=1.0)
                   < PENETRATION for a, b in pairs)

    def dynamic_step(self, sp_v: np.ndarray, sp_w: np.ndarray) -> float:
        """A velocity-motor command on both wheels of every robot (targets from our twist setpoints, torque
        limit from the spec, as the World sets them), then stepSimulation."""
        c = self.client
        r, sep, torque = self.wheel_geom.T
        left, right = ((sp_v - sp_w * sep / 2) / r).tolist(), ((sp_v + sp_w * sep / 2) / r).tolist()
        calls = [(uid, j, [wl, wr], [tq, tq]) for uid, j, wl, wr, tq
                 in zip(self.uids, self.wheels, left, right, torque.tolist(), strict=True)]
        c0, t0 = time.process_time(), time.perf_counter()  # the CPU clock read outside the wall window
        for uid, joints, targets, forces in calls:
            p.setJointMotorControlArray(uid, joints, p.VELOCITY_CONTROL, targetVelocities=targets, forces=forces,
                                        physicsClientId=c)
        p.stepSimulation(physicsClientId=c)
        wall = time.perf_counter() - t0
        self.cpu_s += time.process_time() - c0
        return wall

    def robot_poses(self) -> np.ndarray:
        """(n, 3) x, y, yaw of the twin's robots as PyBullet has them (dynamic twins move on their own)."""
        out = np.empty((len(self.uids), 3))
        for k, uid in enumerate(self.uids):
            pos, orn = p.getBasePositionAndOrientation(uid, physicsClientId=self.client)
            out[k] = pos[0], pos[1], p.getEulerFromQuaternion(orn)[2]
        return out

    def lidar_cast(self, pose: np.ndarray) -> tuple[float, int]:
        """rayTestBatch (numThreads=0, ≤16,000 rays a call) of every robot's beams at `pose`, with the World's
        lidar geometry (sim/sensors/lidar.py). Returns (seconds, rays)."""
        cfg = self.lidar
        if cfg is None:
            return 0.0, 0
        x, y, yaw = pose.T
        a = (yaw[:, None] + cfg.angles[None, :]).ravel()
        dirs = np.column_stack([np.cos(a), np.sin(a), np.zeros(a.size)])
        base = np.column_stack([x + cfg.x_offset * np.cos(yaw), y + cfg.x_offset * np.sin(yaw),
                                np.full(x.size, cfg.height)]).repeat(cfg.angles.size, axis=0)
        origins, ends = base + dirs * cfg.range_min, base + dirs * cfg.range_max
        chunks = [(origins[k:k + MAX_RAYS_PER_CALL].tolist(), ends[k:k + MAX_RAYS_PER_CALL].tolist())
                  for k in range(0, len(origins), MAX_RAYS_PER_CALL)]
        t0 = time.perf_counter()
        for o, e in chunks:
            p.rayTestBatch(o, e, numThreads=0, physicsClientId=self.client)
        return time.perf_counter() - t0, len(origins)
