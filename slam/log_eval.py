"""Trajectory files and metrics for recorded-log SLAM: TUM files, ATE after SE(2) alignment, relative pose
error over consecutive scans and over travelled distances (1 m, 10 m), and g2o export.

TUM format: one pose per line, `t x y z qx qy qz qw` (z = 0, a rotation about z only).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sim.errors import ErrorCode, FleetError
from slam import se2
from slam.metrics import align_se2


def write_tum(path: str | Path, stamps: np.ndarray, poses: np.ndarray) -> Path:
    p = Path(path)
    lines = [f"{t:.6f} {x:.6f} {y:.6f} 0 0 0 {math.sin(th / 2):.9f} {math.cos(th / 2):.9f}"
             for t, (x, y, th) in zip(stamps, poses, strict=True)]
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps (n,), poses (n, 3)); the yaw is taken from the quaternion's rotation about z."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc
    rows = []
    for no, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            v = [float(t) for t in line.split()]
            if len(v) != 8:
                raise ValueError(f"{len(v)} fields")
        except ValueError as exc:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}:{no}: not a TUM pose line ({exc})",
                             "expected 8 numbers: t x y z qx qy qz qw") from exc
        t, x, y, _z, qx, qy, qz, qw = v
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        rows.append((t, x, y, yaw))
    if len(rows) < 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}: fewer than 2 poses", "give a TUM trajectory file")
    a = np.array(rows)
    return a[:, 0], a[:, 1:]


def associate(stamps: np.ndarray, ref_stamps: np.ndarray, tol: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i in est, j in ref) with the nearest stamp within `tol` s. If the stamps are unusable
    (all equal, e.g. zero stamps) but the lengths agree, poses are paired by index."""
    if len(stamps) == len(ref_stamps) and (np.ptp(stamps) == 0 or np.allclose(stamps, ref_stamps)):
        k = np.arange(len(stamps))
        return k, k
    order = np.argsort(ref_stamps)
    rs = ref_stamps[order]
    j = np.clip(np.searchsorted(rs, stamps), 1, max(len(rs) - 1, 1))
    j = np.where(np.abs(rs[j - 1] - stamps) <= np.abs(rs[np.minimum(j, len(rs) - 1)] - stamps), j - 1, j)
    j = np.minimum(j, len(rs) - 1)
    ok = np.abs(rs[j] - stamps) <= tol
    return np.nonzero(ok)[0], order[j[ok]]


def _rpe(est: np.ndarray, ref: np.ndarray, pairs: tuple[np.ndarray, np.ndarray]) -> dict[str, float | int]:
    i, j = pairs
    if len(i) == 0:
        return {"pairs": 0}
    e = se2.between_many(se2.between_many(ref[i], ref[j]), se2.between_many(est[i], est[j]))
    t = np.hypot(e[:, 0], e[:, 1])
    r = np.degrees(np.abs(e[:, 2]))
    return {"pairs": len(i), "trans_mean": float(t.mean()), "trans_std": float(t.std()),
            "rot_mean_deg": float(r.mean()), "rot_std_deg": float(r.std()),
            "rot_rmse_deg": float(np.sqrt(np.mean(r ** 2)))}


def distance_pairs(ref: np.ndarray, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Each pose paired with the first later pose at least `delta` m further along the reference path."""
    step = np.hypot(*np.diff(ref[:, :2], axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(step)])
    j = np.searchsorted(s, s + delta)
    ok = j < len(s)
    return np.nonzero(ok)[0], j[ok]


def evaluate(est: np.ndarray, ref: np.ndarray) -> dict[str, object]:
    """ATE (after the SE(2) alignment that minimises it) and RPE of time-matched (n, 3) arrays."""
    est, ref = np.asarray(est, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    if est.shape != ref.shape or len(est) < 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"need two equal (n≥2, 3) pose arrays, got {est.shape} and "
                         f"{ref.shape}", "associate the trajectories by stamp first")
    t = align_se2(est[:, :2], ref[:, :2])
    aligned = se2.compose_many(np.tile(t, (len(est), 1)), est)
    e = np.hypot(*(aligned[:, :2] - ref[:, :2]).T)
    k = np.arange(len(est) - 1)
    return {"poses": len(est), "ate_rmse": float(np.sqrt(np.mean(e ** 2))), "ate_mean": float(e.mean()),
            "ate_max": float(e.max()), "alignment": [float(v) for v in t],
            "rpe_consecutive": _rpe(est, ref, (k, k + 1)), "rpe_1m": _rpe(est, ref, distance_pairs(ref, 1.0)),
            "rpe_10m": _rpe(est, ref, distance_pairs(ref, 10.0))}


def evaluate_files(traj: str | Path, ref: str | Path, tol: float = 0.02) -> dict[str, object]:
    ts, est = read_tum(traj)
    rs, rp = read_tum(ref)
    i, j = associate(ts, rs, tol)
    if len(i) < 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"only {len(i)} poses of {traj} have a reference pose "
                         f"within {tol} s", "are both files from the same log? (raise --tolerance)")
    out = evaluate(est[i], rp[j])
    out["matched"] = len(i)
    return out


def write_g2o(path: str | Path, poses: np.ndarray, edges: list[tuple[int, int, tuple[float, float, float],
                                                                      np.ndarray]]) -> Path:
    """VERTEX_SE2 per pose, EDGE_SE2 per constraint (upper triangle of the information matrix)."""
    lines = [f"VERTEX_SE2 {k} {x:.6f} {y:.6f} {th:.6f}" for k, (x, y, th) in enumerate(poses)]
    for i, j, rel, cov in edges:
        info = np.linalg.inv(cov)
        u = [info[0, 0], info[0, 1], info[0, 2], info[1, 1], info[1, 2], info[2, 2]]
        lines.append(f"EDGE_SE2 {i} {j} {rel[0]:.6f} {rel[1]:.6f} {rel[2]:.6f} " + " ".join(f"{v:.6g}" for v in u))
    p = Path(path)
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p
