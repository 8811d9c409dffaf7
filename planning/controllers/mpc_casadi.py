"""Nonlinear MPC on the unicycle with CasADi (multiple shooting), warm-started from the shifted last plan.

Cost: along/cross-track error in the reference's frame, input deviation and input-rate terms, and an
obstacle penalty w·max(0, d_safe − clearance(p_k))², where clearance is the costmap's distance field,
linearised around the previous plan each tick (value and finite-difference gradient at each predicted
point) so the solver sees a smooth, cheap function. Constraints: the model, v/ω bounds, |Δu| ≤ a·dt.
Solver: `sqpmethod` with `qrqp` (default; the faster of the two in benchmarks/navigation.py) or IPOPT.
"""

from __future__ import annotations

import math
import time
from typing import Any, Literal

import casadi as ca
import numpy as np
from pydantic import Field

from planning.controllers.base import ControllerConfig, RateLimiter, register_controller
from planning.controllers.ltv_qp import unicycle_rollout
from planning.controllers.reference import PathReference
from planning.nav_types import ControlOutput
from planning.types import Costmap
from sim.types import Pose2D

SolverName = Literal["sqpmethod", "ipopt"]


class CasadiMpcConfig(ControllerConfig):
    type: str = "mpc_casadi"
    horizon: int = Field(20, ge=5, le=100)
    dt: float = Field(0.1, gt=0)
    solver: SolverName = "sqpmethod"
    q_along: float = Field(5.0, ge=0)
    q_cross: float = Field(60.0, ge=0)
    q_yaw: float = Field(4.0, ge=0)
    terminal_scale: float = Field(5.0, ge=1)
    r_v: float = Field(0.5, ge=0)
    r_w: float = Field(0.2, ge=0)
    rd_v: float = Field(2.0, ge=0)
    rd_w: float = Field(0.5, ge=0)
    obstacle_weight: float = Field(200.0, ge=0)
    obstacle_margin: float = Field(0.15, ge=0, description="keep clearance ≥ robot radius + this, m")
    max_iter: int = Field(20, ge=1)


@register_controller("mpc_casadi", CasadiMpcConfig)
class CasadiMpc:
    name = "mpc_casadi"

    def __init__(self, *, max_v: float, max_w: float, max_a: float, max_alpha: float, min_linear: float = 0.0,
                 horizon: int = 20, dt: float = 0.1, solver: SolverName = "sqpmethod", q_along: float = 5.0,
                 q_cross: float = 60.0, q_yaw: float = 4.0, terminal_scale: float = 5.0, r_v: float = 0.5,
                 r_w: float = 0.2, rd_v: float = 2.0, rd_w: float = 0.5, obstacle_weight: float = 200.0,
                 obstacle_margin: float = 0.15, max_iter: int = 20) -> None:
        self.n, self.dt, self.solver_name = horizon, dt, solver
        self.margin = obstacle_margin
        self.limit = RateLimiter(max_v=max_v, max_w=max_w, max_a=max_a, max_alpha=max_alpha, min_v=min_linear)
        self._solver = _build_solver(horizon, dt, solver, max_iter, (q_along, q_cross, q_yaw, terminal_scale),
                                     (r_v, r_w, rd_v, rd_w), obstacle_weight)
        n = horizon
        self._lbx = np.concatenate([np.full(3 * (n + 1), -np.inf), np.tile([min_linear, -max_w], n)])
        self._ubx = np.concatenate([np.full(3 * (n + 1), np.inf), np.tile([max_v, max_w], n)])
        rate = np.tile([max_a * dt, max_alpha * dt], n)
        self._lbg = np.concatenate([np.zeros(3 * (n + 1)), -rate])
        self._ubg = np.concatenate([np.zeros(3 * (n + 1)), rate])
        self._ref: PathReference | None = None
        self._s = 0.0
        self._warm: dict[str, np.ndarray] | None = None

    def reset(self) -> None:
        self.limit.reset()
        self._ref, self._warm = None, None

    def compute(self, pose: Pose2D, twist: tuple[float, float], ref: PathReference, *, now: float,
                costmap: Costmap | None = None) -> ControlOutput:
        hint = None if ref is not self._ref else self._s
        if ref is not self._ref:
            self._ref, self._warm = ref, None
        self._s, lateral = ref.project(pose.x, pose.y, hint)
        n = self.n

        # 1. reference, initial state on the reference's yaw branch, previous command
        x_ref, u_ref = ref.horizon(self._s, n, self.dt, pose.yaw)
        x0 = np.array([pose.x, pose.y, x_ref[0, 2] + math.remainder(pose.yaw - x_ref[0, 2], 2 * math.pi)])
        u_prev = np.asarray(self.limit.previous(twist), dtype=float)

        # 2. initial guess: the shifted last plan, else the reference; linearise the clearance around it
        guess = self._shifted_guess(x_ref) if self._warm is not None else np.concatenate(
            [np.vstack([x0, x_ref[1:]]).ravel(), u_ref.ravel()])
        xs_guess = guess[:3 * (n + 1)].reshape(-1, 3)
        clr = _clearance_model(costmap, xs_guess[:, :2], self.margin)
        p = np.concatenate([x0, x_ref.ravel(), u_ref.ravel(), u_prev, clr.ravel()])

        # 3. solve
        args: dict[str, Any] = dict(x0=guess, p=p, lbx=self._lbx, ubx=self._ubx, lbg=self._lbg,
                                       ubg=self._ubg)
        if self._warm is not None:
            args.update(lam_x0=self._warm["lam_x"], lam_g0=self._warm["lam_g"])
        t0 = time.perf_counter()
        sol = self._solver(**args)
        solve_time = time.perf_counter() - t0
        stats = self._solver.stats()
        # a vanishing SQP step means a stationary point even when the KKT tolerance was not reached
        ok = bool(stats["success"]) or stats.get("return_status") == "Search_Direction_Becomes_Too_Small"
        z = np.asarray(sol["x"]).ravel()
        xs, us = z[:3 * (n + 1)].reshape(-1, 3), z[3 * (n + 1):].reshape(-1, 2)
        if ok and np.all(np.isfinite(z)):
            self._warm = {"x": z, "lam_x": np.asarray(sol["lam_x"]).ravel(),
                          "lam_g": np.asarray(sol["lam_g"]).ravel()}
        else:  # fall back to feed-forward along the reference, start cold next tick
            ok, self._warm, us = False, None, u_ref
            xs = unicycle_rollout(x0, u_ref, self.dt)
        v, w = self.limit(float(us[0, 0]), float(us[0, 1]), now, twist, self.dt)
        return ControlOutput(v=v, w=w, progress=self._s, cross_track=lateral, solve_time_s=solve_time,
                             converged=ok, predicted=xs)

    def _shifted_guess(self, x_ref: np.ndarray) -> np.ndarray:
        assert self._warm is not None
        n = self.n
        z = self._warm["x"]
        xs, us = z[:3 * (n + 1)].reshape(-1, 3), z[3 * (n + 1):].reshape(-1, 2)
        xs = np.vstack([xs[1:], xs[-1:]])
        xs[:, 2] = x_ref[:, 2] + np.remainder(xs[:, 2] - x_ref[:, 2] + math.pi, 2 * math.pi) - math.pi
        return np.concatenate([xs.ravel(), np.vstack([us[1:], us[-1:]]).ravel()])


def _clearance_model(costmap: Costmap | None, pts: np.ndarray, margin: float) -> np.ndarray:
    """Per point: (d_safe − c, gx, gy, px, py) so that violation(p) ≈ d_safe − c − g·(p − p̂)."""
    out = np.zeros((pts.shape[0], 5))
    out[:, 0] = -1e3  # no costmap: never active
    out[:, 3:] = pts
    if costmap is None:
        return out
    h = max(costmap.resolution, 1e-3)
    ex, ey = np.array([h, 0.0]), np.array([0.0, h])
    probe = np.concatenate([pts, pts + ex, pts - ex, pts + ey, pts - ey])
    c = costmap.clearance_many(probe).reshape(5, -1)
    out[:, 0] = costmap.robot_radius + margin - c[0]
    out[:, 1] = (c[1] - c[2]) / (2 * h)
    out[:, 2] = (c[3] - c[4]) / (2 * h)
    return out


def _build_solver(n: int, dt: float, solver: SolverName, max_iter: int,
                  q: tuple[float, float, float, float], r: tuple[float, float, float, float],
                  w_obs: float) -> ca.Function:
    q_along, q_cross, q_yaw, term = q
    r_v, r_w, rd_v, rd_w = r
    X = ca.SX.sym("X", 3, n + 1)
    U = ca.SX.sym("U", 2, n)
    x0, xr, ur = ca.SX.sym("x0", 3), ca.SX.sym("xr", 3, n + 1), ca.SX.sym("ur", 2, n)
    up, obs = ca.SX.sym("up", 2), ca.SX.sym("obs", 5, n + 1)
    cost = ca.SX(0)
    for k in range(n + 1):
        wk = term if k == n else 1.0
        ex, ey = X[0, k] - xr[0, k], X[1, k] - xr[1, k]
        c, s = ca.cos(xr[2, k]), ca.sin(xr[2, k])
        along, cross = c * ex + s * ey, -s * ex + c * ey
        cost += 0.5 * wk * (q_along * along**2 + q_cross * cross**2 + q_yaw * (X[2, k] - xr[2, k]) ** 2)
        viol = obs[0, k] - obs[1, k] * (X[0, k] - obs[3, k]) - obs[2, k] * (X[1, k] - obs[4, k])
        cost += 0.5 * w_obs * ca.fmax(0, viol) ** 2
    g = [X[:, 0] - x0]
    rates = []
    for k in range(n):
        th = X[2, k] + 0.5 * U[1, k] * dt
        nxt = ca.vertcat(X[0, k] + dt * U[0, k] * ca.cos(th), X[1, k] + dt * U[0, k] * ca.sin(th),
                         X[2, k] + dt * U[1, k])
        g.append(X[:, k + 1] - nxt)
        du = U[:, k] - (up if k == 0 else U[:, k - 1])
        rates.append(du)
        e = U[:, k] - ur[:, k]
        cost += 0.5 * (r_v * e[0] ** 2 + r_w * e[1] ** 2 + rd_v * du[0] ** 2 + rd_w * du[1] ** 2)
    nlp = {"x": ca.vertcat(ca.vec(X), ca.vec(U)), "p": ca.vertcat(x0, ca.vec(xr), ca.vec(ur), up, ca.vec(obs)),
           "f": cost, "g": ca.vertcat(*g, *rates)}
    if solver == "ipopt":
        opts: dict[str, Any] = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                                "ipopt.max_iter": max_iter * 5, "ipopt.warm_start_init_point": "yes",
                                "ipopt.tol": 1e-6, "expand": True}
    else:  # exact Hessian, no convexification: "regularize" stalled the SQP at max_iter on this near-convex NLP
        opts = {"qpsol": "qrqp", "print_time": False, "print_header": False, "print_iteration": False,
                "print_status": False, "max_iter": max_iter, "error_on_fail": False, "expand": True,
                "tol_du": 1e-6, "tol_pr": 1e-6,
                "qpsol_options": {"print_iter": False, "print_header": False, "print_info": False,
                                  "error_on_fail": False}}
    return ca.nlpsol("mpc", solver, nlp, opts)
