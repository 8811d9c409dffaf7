"""The QP of the LTV MPC with a fixed sparsity pattern: built once, refilled in place every tick.

Variables z = [δx₀ … δx_N, δu₀ … δu_{N-1}] (deviations from the reference). Cost
½ Σ δx_kᵀ Q_k δx_k + ½ Σ δu_kᵀ R δu_k + ½ Σ (u_k − u_{k−1})ᵀ Rd (u_k − u_{k−1}), with Q_k the along/cross-track
weights rotated into the reference heading. Constraints: δx₀ = x₀ − x_ref,₀; linearised dynamics with the
reference's own model residual; input bounds; rate bounds |u_k − u_{k−1}| ≤ a·dt (u₋₁ = the last command).
Entries that vary are kept in the pattern even when they are momentarily 0 (e.g. sin θ = 0), so OSQP's
factorisation symbolic structure never changes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

NX, NU = 3, 2


def unicycle_step(x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    """Midpoint-heading unicycle step (second order in dt), vectorised over leading axes."""
    th = x[..., 2] + 0.5 * u[..., 1] * dt
    return np.stack([x[..., 0] + dt * u[..., 0] * np.cos(th), x[..., 1] + dt * u[..., 0] * np.sin(th),
                     x[..., 2] + dt * u[..., 1]], axis=-1)


def unicycle_rollout(x0: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    """States (n+1, 3) from x0 under inputs u (n, 2)."""
    xs = np.empty((u.shape[0] + 1, NX))
    xs[0] = x0
    for k in range(u.shape[0]):
        xs[k + 1] = unicycle_step(xs[k], u[k], dt)
    return xs


class _Pattern:
    """Triplets → CSC, remembering where each named varying entry lands in `data`."""

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self.rows: list[int] = []
        self.cols: list[int] = []
        self.vals: list[float] = []

    def add(self, r: int, c: int, v: float = 0.0) -> int:
        self.rows.append(r)
        self.cols.append(c)
        self.vals.append(v)
        return len(self.rows) - 1

    def build(self) -> tuple[sp.csc_matrix, np.ndarray]:
        rows, cols = np.array(self.rows), np.array(self.cols)
        order = np.lexsort((rows, cols))
        if np.any((np.diff(cols[order]) == 0) & (np.diff(rows[order]) == 0)):
            raise ValueError("duplicate entry in QP pattern")
        indptr = np.searchsorted(cols[order], np.arange(self.shape[1] + 1))
        m = sp.csc_matrix((np.array(self.vals)[order], rows[order], indptr), shape=self.shape)
        slot = np.empty_like(order)
        slot[order] = np.arange(order.size)  # triplet i is data[slot[i]]
        return m, slot


class LtvQp:
    def __init__(self, *, horizon: int, dt: float, q_along: float, q_cross: float, q_yaw: float,
                 terminal_scale: float, r: tuple[float, float], rd: tuple[float, float],
                 u_min: tuple[float, float], u_max: tuple[float, float], rate: tuple[float, float]) -> None:
        n = self.n = horizon
        self.dt = dt
        self.nxv, self.nz = NX * (n + 1), NX * (n + 1) + NU * n
        self.q_along, self.q_cross, self.q_yaw, self.term = q_along, q_cross, q_yaw, terminal_scale
        self.rd = np.asarray(rd, dtype=float)
        self.u_min, self.u_max, self.rate = (np.asarray(a, dtype=float) for a in (u_min, u_max, rate))
        self._build_cost(np.asarray(r, dtype=float))
        self._build_constraints()

    def ix(self, k: int) -> int:
        return NX * k

    def iu(self, k: int) -> int:
        return self.nxv + NU * k

    def _build_cost(self, r: np.ndarray) -> None:
        pat = _Pattern((self.nz, self.nz))
        # per stage: xx, xy, yy (vary with heading), yaw·yaw (constant but weighted)
        self._pq = np.array([[pat.add(self.ix(k), self.ix(k)), pat.add(self.ix(k), self.ix(k) + 1),
                              pat.add(self.ix(k) + 1, self.ix(k) + 1),
                              pat.add(self.ix(k) + 2, self.ix(k) + 2)] for k in range(self.n + 1)])
        for k in range(self.n):  # R + Rd on the diagonal (twice inside the horizon), −Rd between stages
            for j in range(NU):
                diag = r[j] + self.rd[j] * (2.0 if k < self.n - 1 else 1.0)
                pat.add(self.iu(k) + j, self.iu(k) + j, diag)
                if k > 0:
                    pat.add(self.iu(k - 1) + j, self.iu(k) + j, -self.rd[j])
        self.P, slot = pat.build()
        self._pq = slot[self._pq]
        self.q = np.zeros(self.nz)

    def _build_constraints(self) -> None:
        n = self.n
        m = self.nxv + 2 * NU * n
        pat = _Pattern((m, self.nz))
        for i in range(NX):
            pat.add(i, i, 1.0)  # δx₀ = e₀
        var = []  # per stage: −dt v sθ, dt v cθ, dt cθ, dt sθ, −dt² v sθ/2, dt² v cθ/2
        for k in range(n):
            r0, xk, xk1, uk = NX * (k + 1), self.ix(k), self.ix(k + 1), self.iu(k)
            for i in range(NX):
                pat.add(r0 + i, xk + i, 1.0)
                pat.add(r0 + i, xk1 + i, -1.0)
            pat.add(r0 + 2, uk + 1, self.dt)
            var.append([pat.add(r0, xk + 2), pat.add(r0 + 1, xk + 2), pat.add(r0, uk), pat.add(r0 + 1, uk),
                        pat.add(r0, uk + 1), pat.add(r0 + 1, uk + 1)])
        rb, rr = self.nxv, self.nxv + NU * n  # input-bound rows, rate rows
        for k in range(n):
            for j in range(NU):
                pat.add(rb + NU * k + j, self.iu(k) + j, 1.0)
                pat.add(rr + NU * k + j, self.iu(k) + j, 1.0)
                if k > 0:
                    pat.add(rr + NU * k + j, self.iu(k - 1) + j, -1.0)
        self.A, slot = pat.build()
        self._av = slot[np.array(var)]
        self.l, self.u = np.zeros(m), np.zeros(m)

    def fill(self, x_ref: np.ndarray, u_ref: np.ndarray, x0: np.ndarray, u_prev: np.ndarray) -> None:
        """Write this tick's numbers into P.data, A.data, q, l, u (shapes and patterns unchanged)."""
        n, dt = self.n, self.dt
        # cost: along/cross-track weights rotated into each reference heading
        c, s = np.cos(x_ref[:, 2]), np.sin(x_ref[:, 2])
        w = np.ones(n + 1)
        w[-1] = self.term
        qa, qc = self.q_along * w, self.q_cross * w
        pd = self.P.data
        pd[self._pq[:, 0]] = qa * c * c + qc * s * s
        pd[self._pq[:, 1]] = (qa - qc) * c * s
        pd[self._pq[:, 2]] = qa * s * s + qc * c * c
        pd[self._pq[:, 3]] = self.q_yaw * w
        # linear cost from the rate penalty on the reference's own input changes (u₋₁ = last command)
        du_ref = np.diff(np.vstack([u_prev, u_ref]), axis=0) * self.rd  # (n, 2)
        qu = du_ref.copy()
        qu[:-1] -= du_ref[1:]
        self.q[self.nxv:] = qu.ravel()
        # dynamics: Jacobians at the reference, residual of the reference under the model
        v, om = u_ref[:, 0], u_ref[:, 1]
        th = x_ref[:-1, 2] + 0.5 * om * dt
        ct, st = np.cos(th), np.sin(th)
        vals = np.column_stack([-dt * v * st, dt * v * ct, dt * ct, dt * st, -0.5 * dt * dt * v * st,
                                0.5 * dt * dt * v * ct])
        self.A.data[self._av] = vals
        resid = unicycle_step(x_ref[:-1], u_ref, dt) - x_ref[1:]
        self.l[:NX] = self.u[:NX] = x0 - x_ref[0]
        self.l[NX:self.nxv] = self.u[NX:self.nxv] = -resid.ravel()
        rb, rr = self.nxv, self.nxv + NU * n
        self.l[rb:rr] = (self.u_min - u_ref).ravel()
        self.u[rb:rr] = (self.u_max - u_ref).ravel()
        base = -np.diff(np.vstack([u_prev, u_ref]), axis=0)  # δu_k − δu_{k−1} = Δu − Δu_ref
        self.l[rr:] = (base - self.rate).ravel()
        self.u[rr:] = (base + self.rate).ravel()

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return z[:self.nxv].reshape(-1, NX), z[self.nxv:].reshape(-1, NU)

    def warm_start(self, xs: np.ndarray, us: np.ndarray, x_ref: np.ndarray, u_ref: np.ndarray) -> np.ndarray:
        """The previous absolute plan shifted one stage, as deviations from the new reference."""
        xw = np.vstack([xs[1:], xs[-1:]])
        uw = np.vstack([us[1:], us[-1:]])
        xw[:, 2] = x_ref[:, 2] + np.remainder(xw[:, 2] - x_ref[:, 2] + math.pi, 2 * math.pi) - math.pi
        return np.concatenate([(xw - x_ref).ravel(), (uw - u_ref).ravel()])
