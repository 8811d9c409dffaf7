"""Leader-follower: followers hold slots fixed in the leader's body frame, u_i = v_L + k (p_L + R(θ_L) o_i − p_i).

The leader is not driven by the behaviour (a task, a manual client or another behaviour moves it);
`velocities` returns NaN for its row. Slots come from a formation shape with the leader at its first slot
(the apex of a wedge, the head of a column). Outcome: formation error (RMS distance of followers from
their slots) and the leader's speed.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from fleet.formations import SHAPES, assign_slots, check_kind, formation_offsets
from fleet.swarm.registry import register_behaviour
from fleet.swarm.types import BehaviourConfig, SwarmState
from sim.errors import ErrorCode, FleetError


class LeaderFollowerConfig(BehaviourConfig):
    type: str = "leader_follower"
    leader: str | None = Field(None, description="null: the first robot")
    shape: str = Field("wedge", description=f"one of {', '.join(SHAPES)}; the leader takes the first slot")
    spacing: float = Field(1.5, gt=0, description="m")
    gain: float = Field(0.8, gt=0, description="1/s")
    tolerance: float = Field(0.2, gt=0, description="converged below this RMS error, m")


@register_behaviour("leader_follower", LeaderFollowerConfig, min_robots=2)
class LeaderFollower:
    name = "leader_follower"
    separates_itself = True  # its own law keeps the robots apart: avoidance only against outsiders

    def __init__(self, *, leader: str | None = None, shape: str = "wedge", spacing: float = 1.5, gain: float = 0.8,
                 tolerance: float = 0.2) -> None:
        self.leader_name, self.shape, self.spacing = leader, check_kind(shape, SHAPES), spacing
        self.gain, self.tol = gain, tolerance
        self.leader = 0
        self.slots = np.zeros((0, 2))  # leader body frame, row per robot (leader's row is 0)

    def start(self, state: SwarmState) -> None:
        if self.leader_name is not None:
            if self.leader_name not in state.names:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"leader '{self.leader_name}' is not one of the "
                                 "behaviour's robots", f"robots: {', '.join(state.names)}")
            self.leader = state.names.index(self.leader_name)
        off = formation_offsets(self.shape, len(state.names), self.spacing)
        off = off - off[0]  # leader at the first slot
        followers = [i for i in range(len(state.names)) if i != self.leader]
        body = self._to_body(state, state.xy[followers])
        perm = assign_slots(body, off[1:])
        self.slots = np.zeros((len(state.names), 2))
        self.slots[followers] = off[1:][perm]

    def _to_body(self, state: SwarmState, xy: np.ndarray) -> np.ndarray:
        c, s = math.cos(state.yaw[self.leader]), math.sin(state.yaw[self.leader])
        d = xy - state.xy[self.leader]
        return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]])

    def _targets(self, state: SwarmState) -> np.ndarray:
        c, s = math.cos(state.yaw[self.leader]), math.sin(state.yaw[self.leader])
        rot = np.array([[c, -s], [s, c]])
        return np.asarray(state.xy[self.leader] + self.slots @ rot.T)

    def velocities(self, state: SwarmState) -> np.ndarray:
        u = state.velocity[self.leader] + self.gain * (self._targets(state) - state.xy)
        u[self.leader] = np.nan  # not ours to drive
        return np.asarray(u)

    def metrics(self, state: SwarmState) -> dict[str, float]:
        e = np.delete(self._targets(state) - state.xy, self.leader, axis=0)
        return {"formation_error_m": float(np.sqrt((e**2).sum(axis=1).mean())),
                "leader_speed": float(abs(state.v[self.leader]))}

    def converged(self, state: SwarmState, metrics: dict[str, float]) -> bool:
        return metrics["formation_error_m"] <= self.tol
