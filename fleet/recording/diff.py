"""Diff two runs: assertions that changed verdict, metrics that moved, and how far trajectories part.

A run is its output folder (report.json, and recording.mcap when there is one), a report.json, or a
recording.mcap. Wall-clock figures (the report's `wall` section) are never compared: they differ every run.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from fleet.recording.reader import states
from fleet.recording.types import DiffResult
from sim.errors import ErrorCode, FleetError

IGNORED = ("wall",)


def diff_runs(a: str | Path, b: str | Path, tol: float = 1e-9) -> DiffResult:
    (ra, ma), (rb, mb) = _resolve(Path(a)), _resolve(Path(b))
    out = DiffResult(str(a), str(b))
    if ra is not None and rb is not None:
        _reports(out, ra, rb, tol)
    if ma is not None and mb is not None:
        out.trajectories = trajectory_gaps(ma, mb)
        out.trajectories = {k: (0.0 if v <= tol else v) for k, v in out.trajectories.items()}
    if (ra is None or rb is None) and (ma is None or mb is None):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"nothing comparable in {a} and {b}",
                         "give two run folders, two report.json files or two recording.mcap files")
    return out


def _resolve(p: Path) -> tuple[dict[str, Any] | None, Path | None]:
    if p.is_dir():
        rep, rec = p / "report.json", p / "recording.mcap"
        return (json.loads(rep.read_text()) if rep.is_file() else None), (rec if rec.is_file() else None)
    if p.suffix == ".json" and p.is_file():
        return json.loads(p.read_text()), None
    if p.suffix == ".mcap" and p.is_file():
        return None, p
    raise FleetError(ErrorCode.NOT_FOUND, f"no run at {p}", "give a run folder, a report.json or a recording.mcap")


def _reports(out: DiffResult, ra: dict[str, Any], rb: dict[str, Any], tol: float) -> None:
    va = {x["name"]: x for x in ra.get("assertions", [])}
    vb = {x["name"]: x for x in rb.get("assertions", [])}
    for name in sorted(set(va) & set(vb)):
        if va[name]["passed"] != vb[name]["passed"] or va[name]["measured"] != vb[name]["measured"]:
            out.verdicts.append({"name": name, "a": va[name]["passed"], "b": vb[name]["passed"],
                                 "measured_a": va[name]["measured"], "measured_b": vb[name]["measured"]})
    fa, fb = flatten({k: v for k, v in ra.items() if k not in IGNORED}), \
        flatten({k: v for k, v in rb.items() if k not in IGNORED})
    out.only_in = {"a": sorted(set(fa) - set(fb)), "b": sorted(set(fb) - set(fa))}
    for key in sorted(set(fa) & set(fb)):
        x, y = fa[key], fb[key]
        if isinstance(x, int | float) and isinstance(y, int | float) and not isinstance(x, bool):
            if not (math.isclose(x, y, abs_tol=tol, rel_tol=0.0)):
                out.metrics.append({"key": key, "a": x, "b": y, "delta": y - x})
        elif x != y:
            out.metrics.append({"key": key, "a": x, "b": y})


def flatten(d: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(d, dict):
        out: dict[str, Any] = {}
        for k, v in d.items():
            out |= flatten(v, f"{prefix}.{k}" if prefix else str(k))
        return out
    if isinstance(d, list) and d and all(isinstance(x, dict) and "name" in x for x in d):
        return flatten({x["name"]: x for x in d}, prefix)
    return {prefix: d}


def trajectory_gaps(a: Path, b: Path) -> dict[str, float]:
    """Per robot, the largest position difference at the control ticks both recordings have."""
    ta, tb = _tracks(a), _tracks(b)
    gaps: dict[str, float] = {}
    for name in sorted(set(ta) | set(tb)):
        if name not in ta or name not in tb:
            gaps[name] = math.inf
            continue
        common = sorted(set(ta[name]) & set(tb[name]))
        if not common:
            gaps[name] = math.inf
            continue
        pa = np.array([ta[name][t] for t in common])
        pb = np.array([tb[name][t] for t in common])
        gaps[name] = float(np.hypot(*(pa - pb).T).max())
    return gaps


def _tracks(path: Path) -> dict[str, dict[float, tuple[float, float]]]:
    tracks: dict[str, dict[float, tuple[float, float]]] = {}
    for st in states(path):
        for name, (x, y, _) in zip(st["names"], st["pose"], strict=True):
            tracks.setdefault(name, {})[st["t"]] = (x, y)
    return tracks
