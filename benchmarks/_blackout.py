"""Laser blackout perturbation for `benchmarks/slam_robustness.py`: over one or two stretches of 20–60 m of path
the scans return nothing (every beam max range, "no return") while the odometry goes on, so the estimate
crosses the gap on the raw odometry and drifts before the robot is back in mapped space — what a laser dropout,
a long featureless corridor or an open hall does to a real log.

Choice rule (seeded, the same for every log): a *revisit* is a scan within `near` m of a reference pose at least
`loop_path` m of path earlier (the first scan of each run of such scans). Up to `gaps` revisits are drawn at
random; each gap ends at its revisit and starts L ~ U(20, 60) m of path before it (cut so that it starts after the
earlier visit, with ≥ 20 m of seeing path between gaps; a revisit whose gap would be shorter than 20 m or too
close to a chosen gap is skipped). Drift at a gap's end: the odometry chained across the gap from
the reference pose at its start, against the reference at its end.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.transforms import se2_between, se2_compose
from slam.log_run import LoadedLog
from slam.types import ScanRecord


def path_of(xy: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])


def revisits(ref: np.ndarray, near: float = 1.5, loop_path: float = 60.0) -> list[tuple[int, int]]:
    """(scan, earliest earlier scan it revisits) at the first scan of each run of revisiting scans."""
    path = path_of(ref[:, :2])
    out: list[tuple[int, int]] = []
    prev = False
    for k in range(len(ref)):
        old = np.nonzero(path[k] - path[:k] >= loop_path)[0]
        hit = old[np.hypot(*(ref[old, :2] - ref[k, :2]).T) < near] if len(old) else old
        if len(hit) and not prev:
            out.append((k, int(hit[0])))
        prev = bool(len(hit))
    return out


def choose_gaps(ref: np.ndarray, rng: np.random.Generator, gaps: int = 2, lo: float = 20.0, hi: float = 60.0,
                min_len: float = 20.0, sighted: float = 20.0) -> list[tuple[int, int]]:
    """[start, end) scan ranges of the blackouts (module doc), in log order."""
    path = path_of(ref[:, :2])
    events = revisits(ref)
    out: list[tuple[int, int]] = []
    for j in rng.permutation(len(events)).tolist():
        end, old = events[j]
        length = float(rng.uniform(lo, hi))
        start = int(np.searchsorted(path, path[end] - length))
        start = max(start, old + 1 + int(np.searchsorted(path[old:], path[old] + 5.0)))  # after the first visit
        # at least `sighted` m of seeing path between gaps: the robot must be back in mapped space in between
        if path[end] - path[min(start, end)] < min_len \
                or any(path[start] < path[e] + sighted and path[end] + sighted > path[s] for s, e in out):
            continue
        out.append((start, end))
        if len(out) == gaps:
            break
    return sorted(out)


def blackout(log: LoadedLog, rng: np.random.Generator) -> tuple[LoadedLog, list[tuple[int, int]]]:
    assert log.reference is not None
    spans = choose_gaps(log.reference, rng)
    recs = list(log.records)
    for s, e in spans:
        for k in range(s, e):
            r = recs[k]
            recs[k] = ScanRecord(dataclasses.replace(r.scan, ranges=np.full_like(r.scan.ranges, np.inf),
                                                     hit_bodies=None), r.odom)
    return dataclasses.replace(log, records=recs), spans


def gap_report(log: LoadedLog, spans: list[tuple[int, int]], est: np.ndarray | None = None) -> list[dict[str, float]]:
    """Per gap: path length, the odometry's drift across it (m, deg) and, given the final estimate, its error
    over the gap (relative pose start → end against the reference's)."""
    assert log.reference is not None
    ref = log.reference
    path = path_of(ref[:, :2])
    out = []
    for s, e in spans:
        row = {"start": s, "end": e, "path_m": round(float(path[e] - path[s]), 1)}
        o0, o1 = log.records[s].odom, log.records[e].odom
        if o0 is not None and o1 is not None:
            dr = se2_compose(tuple(ref[s]), se2_between(o0.as_tuple(), o1.as_tuple()))
            d = se2_between(tuple(ref[e]), dr)
            row["odom_drift_m"] = round(math.hypot(d[0], d[1]), 2)
            row["odom_drift_deg"] = round(abs(math.degrees(d[2])), 1)
        if est is not None:
            d = se2_between(se2_between(tuple(ref[s]), tuple(ref[e])), se2_between(tuple(est[s]), tuple(est[e])))
            row["est_err_m"] = round(math.hypot(d[0], d[1]), 3)
            row["est_err_deg"] = round(abs(math.degrees(d[2])), 2)
        out.append(row)
    return out
