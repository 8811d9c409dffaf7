"""Sub-cell refinement of a correlative match on a smooth cost (Cartographer's CeresScanMatcher2D).

The correlative search (`slam.csm`) returns the best pose on a lattice (5 cm, ~0.3°). Cartographer refines
that pose by minimising, over (x, y, θ),

    Σ_i (w_occ/√n · (1 − M(T·p_i)))²  +  (w_t · ‖t − t₀‖)²  +  (w_r · (θ − θ₀))²

where M is the map bicubically interpolated between its cells (`occupied_space_cost_function_2d.cc`: Ceres'
BiCubicInterpolator, i.e. a cubic Hermite spline with central-difference slopes — Catmull-Rom), and the last
two terms tie the result to the prior pose. Here M is the match grid's smoothed hit likelihood and the
problem is solved by a few damped Gauss–Newton (Levenberg–Marquardt) steps in numpy.

Unlike point-to-line ICP it has no correspondences to re-associate: the cost is a smooth function of the
pose everywhere, so it does not snap to the map's points or cycle between two neighbours.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from slam import se2


class RefineConfig(StrictModel):
    """Scan-to-map refinement after the correlative search (`slam.scan_refine`)."""

    occupied_weight: float = Field(1.0, gt=0, description="w_occ: weight of the map term (Cartographer: 1)")
    translation_weight: float = Field(0.1, ge=0, description="w_t: pull towards the search's pose, per m")
    rotation_weight: float = Field(0.4, ge=0, description="w_r: pull towards the search's rotation, per rad")
    max_iterations: int = Field(40, ge=1)
    tolerance: float = Field(1e-5, gt=0, description="stop when a step moves less than this (m, rad)")


@dataclass(frozen=True, slots=True)
class RefineResult:
    pose: se2.PoseTuple
    cost: float  # final cost (map term + prior terms)
    score: float  # mean interpolated map value at the pose (0 … 1)
    hessian: np.ndarray  # Gauss–Newton Hessian JᵀJ of the map term at the pose (3 × 3)
    iterations: int
    converged: bool


# Catmull-Rom weights of the samples at offsets −1, 0, 1, 2 for a fraction t ∈ [0, 1), and their derivatives.
def _weights(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t2, t3 = t * t, t * t * t
    w = 0.5 * np.stack([-t3 + 2 * t2 - t, 3 * t3 - 5 * t2 + 2, -3 * t3 + 4 * t2 + t, t3 - t2], axis=-1)
    dw = 0.5 * np.stack([-3 * t2 + 4 * t - 1, 9 * t2 - 10 * t, -9 * t2 + 8 * t + 1, 3 * t2 - 2 * t], axis=-1)
    return w, dw


class BicubicField:
    """A grid of samples at cell centres (`origin` + (col + ½, row + ½)·resolution), interpolated bicubically
    (Catmull-Rom: C¹, exact at the samples). Outside the grid the value is that of the nearest border
    sample (the match grid's border is 0)."""

    def __init__(self, values: np.ndarray, origin: np.ndarray, resolution: float) -> None:
        self.values = np.asarray(values)
        self.origin = np.asarray(origin, dtype=np.float64).reshape(2)
        self.resolution = float(resolution)

    def evaluate(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n, 2) world points → values (n,) and gradients (n, 2) per metre."""
        q = (np.asarray(xy, dtype=np.float64).reshape(-1, 2) - self.origin) / self.resolution - 0.5
        base = np.floor(q).astype(np.int64)
        wx, dwx = _weights(q[:, 0] - base[:, 0])
        wy, dwy = _weights(q[:, 1] - base[:, 1])
        h, w = self.values.shape
        off = np.arange(-1, 3)
        cols = np.clip(base[:, 0:1] + off, 0, w - 1)
        rows = np.clip(base[:, 1:2] + off, 0, h - 1)
        patch = self.values[rows[:, :, None], cols[:, None, :]]  # (n, 4 rows, 4 cols)
        along_x = np.einsum("nrc,nc->nr", patch, wx)
        value = np.einsum("nr,nr->n", along_x, wy)
        gy = np.einsum("nr,nr->n", along_x, dwy)
        gx = np.einsum("nrc,nc,nr->n", patch, dwx, wy)
        return value, np.column_stack([gx, gy]) / self.resolution


def refine(field: BicubicField, points: np.ndarray, initial: se2.PoseTuple, config: RefineConfig | None = None,
           prior: se2.PoseTuple | None = None) -> RefineResult:
    """Pose of `points` (sensor frame, (n, 2)) that best fits `field`, started at `initial` and tied to
    `prior` (default: `initial`) by the translation / rotation weights."""
    cfg = config or RefineConfig()
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = max(len(pts), 1)
    a = cfg.occupied_weight / np.sqrt(n)
    p0 = np.array(prior if prior is not None else initial, dtype=np.float64)
    wt, wr = cfg.translation_weight, cfg.rotation_weight

    def terms(x: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, float]:
        c, s = np.cos(x[2]), np.sin(x[2])
        wx = c * pts[:, 0] - s * pts[:, 1] + x[0]
        wy = s * pts[:, 0] + c * pts[:, 1] + x[1]
        v, g = field.evaluate(np.column_stack([wx, wy]))
        r = a * (1.0 - v)
        dth = g[:, 0] * (-s * pts[:, 0] - c * pts[:, 1]) + g[:, 1] * (c * pts[:, 0] - s * pts[:, 1])
        jac = -a * np.column_stack([g[:, 0], g[:, 1], dth])
        pr = np.array([wt * (x[0] - p0[0]), wt * (x[1] - p0[1]), wr * (x[2] - p0[2])])
        cost = float(r @ r + pr @ pr)
        h_map = jac.T @ jac
        grad = jac.T @ r + np.array([wt, wt, wr]) * pr
        return cost, h_map, grad, v, float(v.mean()) if len(v) else 0.0

    x = np.array(initial, dtype=np.float64)
    cost, h_map, grad, _, score = terms(x)
    prior_h = np.diag([wt * wt, wt * wt, wr * wr])
    lam = 1e-3
    converged = False
    it = 0
    for it in range(1, cfg.max_iterations + 1):  # noqa: B007 - the count is reported
        h = h_map + prior_h
        step = -np.linalg.solve(h + lam * np.diag(np.diag(h) + 1e-12), grad)
        cand = x + step
        c_cost, c_h, c_grad, _, c_score = terms(cand)
        if c_cost <= cost:
            x, cost, h_map, grad, score = cand, c_cost, c_h, c_grad, c_score
            lam = max(lam / 10, 1e-7)
            if np.abs(step).max() < cfg.tolerance:
                converged = True
                break
        else:
            lam *= 10
            if lam > 1e4:  # no descent direction left: at the minimum (to numerical precision)
                converged = True
                break
    return RefineResult((float(x[0]), float(x[1]), float(x[2])), cost, score, h_map, it, converged)
