"""The benchmark's fleet driver: every robot always commanded to move, along random arcs, reacting to bumps.

Each robot drives an arc (v 0.4–1.0 m/s, |ω| ≤ 0.6 rad/s: turning radius ≥ 0.67 m) for 2–6 s of sim time,
then picks another. A robot whose last move was blocked (the world reverted it) picks a random escape
command (v −0.4…0.8 m/s, |ω| ≤ 1 rad/s) for 0.5–1.5 s. Commands go through the public batched
`World.set_cmd_vels` (set_cmd_vel's clamping, one call per group of robots); bumps are read from the world's
fleet-state table (read-only, one array read instead of 1000 `robot_in_collision` calls a step). Its own
seeded RNG keeps the sim's RNG for the sim.
"""

from __future__ import annotations

import numpy as np

from sim import World


class ArcDriver:
    def __init__(self, world: World, seed: int = 1) -> None:
        self.world = world
        self.names = world.robot_names()
        self.rng = np.random.default_rng(seed)
        self.next_change = np.zeros(len(self.names))  # sim time of each robot's next new command

    def update(self) -> int:
        """Re-command robots whose arc ran out or that were blocked. Returns how many were blocked."""
        now = self.world.time
        blocked = self.world.table.b["in_collision"]
        due = np.flatnonzero((self.next_change <= now) & ~blocked)
        stuck = np.flatnonzero(blocked)
        self._command(due, self.rng.uniform(0.4, 1.0, due.size), self.rng.uniform(-0.6, 0.6, due.size),
                      now + self.rng.uniform(2.0, 6.0, due.size))
        self._command(stuck, self.rng.uniform(-0.4, 0.8, stuck.size), self.rng.uniform(-1.0, 1.0, stuck.size),
                      now + self.rng.uniform(0.5, 1.5, stuck.size))
        return int(stuck.size)

    def _command(self, rows: np.ndarray, v: np.ndarray, w: np.ndarray, until: np.ndarray) -> None:
        if rows.size:  # rows of robot_names(): the fleet's arrays go in as they are, as a fleet controller's would
            self.world.set_cmd_vels(rows, v, w)
        self.next_change[rows] = until
