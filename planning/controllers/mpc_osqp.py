"""Linear-time-varying MPC on the unicycle, solved with OSQP.

The model x⁺ = x + dt·[v cos(θ + ω dt/2), v sin(θ + ω dt/2), ω] is linearised about the reference at every
stage; decision variables are deviations from the reference (δx₀..δx_N, δu₀..δu_{N-1}). The QP's sparsity
pattern is built once (ltv_qp.py) and only its numbers change, so each tick is one in-place
`update(Px, Ax, q, l, u)` and a warm-started solve.
"""

from __future__ import annotations

import math
import time

import numpy as np
import osqp
from pydantic import Field

from planning.controllers.base import ControllerConfig, RateLimiter, register_controller
from planning.controllers.ltv_qp import LtvQp, unicycle_rollout
from planning.controllers.reference import PathReference
from planning.nav_types import ControlOutput
from planning.types import Costmap
from sim.types import Pose2D


class OsqpMpcConfig(ControllerConfig):
    type: str = "mpc_osqp"
    horizon: int = Field(20, ge=5, le=100)
    dt: float = Field(0.1, gt=0, description="MPC step, s")
    q_along: float = Field(5.0, ge=0, description="weight on along-track error")
    q_cross: float = Field(60.0, ge=0, description="weight on cross-track error")
    q_yaw: float = Field(4.0, ge=0)
    terminal_scale: float = Field(5.0, ge=1)
    r_v: float = Field(0.5, ge=0, description="weight on deviation from the reference speed")
    r_w: float = Field(0.2, ge=0)
    rd_v: float = Field(2.0, ge=0, description="weight on speed changes between stages")
    rd_w: float = Field(0.5, ge=0)
    max_iter: int = Field(400, ge=10)
    eps: float = Field(1e-4, gt=0)


@register_controller("mpc_osqp", OsqpMpcConfig)
class OsqpMpc:
    name = "mpc_osqp"

    def __init__(self, *, max_v: float, max_w: float, max_a: float, max_alpha: float, min_linear: float = 0.0,
                 horizon: int = 20, dt: float = 0.1, q_along: float = 5.0, q_cross: float = 60.0,
                 q_yaw: float = 4.0, terminal_scale: float = 5.0, r_v: float = 0.5, r_w: float = 0.2,
                 rd_v: float = 2.0, rd_w: float = 0.5, max_iter: int = 400, eps: float = 1e-4) -> None:
        self.n, self.dt = horizon, dt
        self.qp = LtvQp(horizon=horizon, dt=dt, q_along=q_along, q_cross=q_cross, q_yaw=q_yaw,
                        terminal_scale=terminal_scale, r=(r_v, r_w), rd=(rd_v, rd_w),
                        u_min=(min_linear, -max_w), u_max=(max_v, max_w), rate=(max_a * dt, max_alpha * dt))
        self.limit = RateLimiter(max_v=max_v, max_w=max_w, max_a=max_a, max_alpha=max_alpha, min_v=min_linear)
        self.solver = osqp.OSQP()
        self.solver.setup(self.qp.P, self.qp.q, self.qp.A, self.qp.l, self.qp.u, verbose=False,
                          warm_starting=True, polishing=False, eps_abs=eps, eps_rel=eps, max_iter=max_iter,
                          check_termination=10)
        self._ref: PathReference | None = None
        self._s = 0.0
        self._plan: tuple[np.ndarray, np.ndarray] | None = None  # last absolute (X, U)

    def reset(self) -> None:
        self.limit.reset()
        self._ref, self._plan = None, None

    def compute(self, pose: Pose2D, twist: tuple[float, float], ref: PathReference, *, now: float,
                costmap: Costmap | None = None) -> ControlOutput:
        hint = None if ref is not self._ref else self._s
        if ref is not self._ref:
            self._ref, self._plan = ref, None
        self._s, lateral = ref.project(pose.x, pose.y, hint)

        # 1. reference over the horizon, on the robot's yaw branch
        x_ref, u_ref = ref.horizon(self._s, self.n, self.dt, pose.yaw)
        x0 = np.array([pose.x, pose.y, pose.yaw])
        x0[2] = x_ref[0, 2] + math.remainder(pose.yaw - x_ref[0, 2], 2 * math.pi)
        u_prev = np.asarray(self.limit.previous(twist), dtype=float)

        # 2. refill the fixed-pattern QP and solve, warm-started from the shifted previous plan
        self.qp.fill(x_ref, u_ref, x0, u_prev)
        self.solver.update(Px=self.qp.P.data, Ax=self.qp.A.data, q=self.qp.q, l=self.qp.l, u=self.qp.u)
        if self._plan is not None:
            self.solver.warm_start(x=self.qp.warm_start(*self._plan, x_ref, u_ref))
        t0 = time.perf_counter()
        res = self.solver.solve(raise_error=False)
        solve_time = time.perf_counter() - t0
        ok = res.info.status_val in (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)

        # 3. absolute plan; on failure fall back to the reference's feed-forward input
        if ok:
            dx, du = self.qp.split(res.x)
            xs, us = x_ref + dx, u_ref + du
            self._plan = (xs, us)
        else:
            xs, us = unicycle_rollout(x0, u_ref, self.dt), u_ref
            self._plan = None
        v, w = self.limit(float(us[0, 0]), float(us[0, 1]), now, twist, self.dt)
        return ControlOutput(v=v, w=w, progress=self._s, cross_track=lateral, solve_time_s=solve_time,
                             converged=ok, predicted=xs)

