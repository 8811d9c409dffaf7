"""Trajectory and map metrics: ATE after SE(2) alignment (Umeyama/Horn, no scale), RPE, map IoU."""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import binary_dilation

from planning.grid import OccupancyGrid
from sim.errors import ErrorCode, FleetError
from slam import se2
from slam.grid_lookup import values_at
from slam.types import MapIoU, TrajectoryErrors


def align_se2(est: np.ndarray, truth: np.ndarray) -> tuple[float, float, float]:
    """The rigid transform T minimising Σ‖T·est_i − truth_i‖² over (n, 2) positions (closed form)."""
    me, mt = est.mean(axis=0), truth.mean(axis=0)
    h = (est - me).T @ (truth - mt)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, d]) @ u.T
    t = mt - r @ me
    return (float(t[0]), float(t[1]), math.atan2(r[1, 0], r[0, 0]))


def trajectory_errors(est: np.ndarray, truth: np.ndarray, rpe_delta: int = 10, align: bool = True
                      ) -> TrajectoryErrors:
    """ATE and RPE of (n, 3) estimated poses against time-matched (n, 3) ground truth."""
    est, truth = np.asarray(est, dtype=np.float64), np.asarray(truth, dtype=np.float64)
    if est.shape != truth.shape or est.ndim != 2 or est.shape[1] != 3 or len(est) < 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"need two equal (n≥2, 3) pose arrays, got {est.shape} and "
                         f"{truth.shape}", "match the estimate to ground truth by stamp first")
    t = align_se2(est[:, :2], truth[:, :2]) if align else (0.0, 0.0, 0.0)
    aligned = se2.compose_many(np.tile(t, (len(est), 1)), est)
    e = np.hypot(*(aligned[:, :2] - truth[:, :2]).T)
    d = max(1, min(rpe_delta, len(est) - 1))
    rel_e = se2.between_many(est[:-d], est[d:])
    rel_t = se2.between_many(truth[:-d], truth[d:])
    err = se2.between_many(rel_t, rel_e)
    return TrajectoryErrors(ate_rmse=float(np.sqrt(np.mean(e**2))), ate_mean=float(e.mean()), ate_max=float(e.max()),
                            rpe_trans_rmse=float(np.sqrt(np.mean(err[:, 0] ** 2 + err[:, 1] ** 2))),
                            rpe_rot_rmse=float(np.sqrt(np.mean(err[:, 2] ** 2))), rpe_delta=d, count=len(est),
                            alignment=t)


def match_by_stamp(stamps: np.ndarray, truth_stamps: np.ndarray, truth: np.ndarray, tol: float = 1e-3
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Indices of `stamps` that have a ground-truth pose within `tol` s, and those poses."""
    j = np.clip(np.searchsorted(truth_stamps, stamps), 1, len(truth_stamps) - 1)
    j = np.where(np.abs(truth_stamps[j - 1] - stamps) <= np.abs(truth_stamps[j] - stamps), j - 1, j)
    ok = np.abs(truth_stamps[j] - stamps) <= tol
    return np.nonzero(ok)[0], truth[j[ok]]


def map_iou(est: OccupancyGrid, truth: OccupancyGrid, tolerance_cells: int = 1) -> MapIoU:
    """IoU of occupied and of free cells, on the ground truth's cells the estimate has observed.

    Interiors of solid obstacles and the outside of the building are never seen by a lidar, so they are
    left out (the estimate's known cells, dilated by the tolerance, set the region). An occupied cell
    counts as matched if the other map has one within `tolerance_cells` (map-vs-map alignment slack);
    with 0 it is the plain IoU. `coverage` is the share of ground-truth free cells the estimate knows.
    """
    xs, ys = truth.cell_centres()
    e = values_at(est, np.column_stack([xs.ravel(), ys.ravel()])).reshape(truth.data.shape)
    e_known, e_occ, e_free = e >= 0, e >= 65, (e >= 0) & (e < 65)
    t_occ, t_free = truth.occupied(), truth.free()
    k = np.ones((2 * tolerance_cells + 1,) * 2, dtype=bool)
    dil = (lambda m: binary_dilation(m, k)) if tolerance_cells > 0 else (lambda m: m)
    region = dil(e_known)
    a, b = e_occ, t_occ & region
    inter = 0.5 * ((a & dil(b)).sum() + (b & dil(a)).sum())
    occ = float(inter / max(1e-9, a.sum() + b.sum() - inter))
    fa, fb = e_free, t_free & e_known
    free = float((fa & fb).sum() / max(1, (fa | fb).sum()))
    coverage = float((e_known & t_free).sum() / max(1, t_free.sum()))
    return MapIoU(occupied=occ, free=free, mean=0.5 * (occ + free), tolerance_cells=tolerance_cells,
                  coverage=coverage)
