"""A challenge's report files: report.json (everything), report.md, report.html (self-contained, with the
trajectory plot, the per-run table and the rubric points), trajectories.png and one CSV per run.

The plot is the missions' trajectory plot (fleet.missions.plot): the optimal path is drawn first (red),
then each run's driven path, with a ring where each collision began.
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from fleet.grading.types import TRAJ_COLUMNS, ChallengeReport
from fleet.missions.plot import save_plot
from fleet.missions.types import RunData, TaskRecord
from planning import rasterize_world
from sim.types import Pose2D, WorldDescription

RUN_COLUMNS = [("run", "run"), ("seed", "seed"), ("outcome", "outcome"), ("score", "score"), ("time", "T s"),
               ("path_length", "path m"), ("spl", "SPL"), ("collisions", "collisions"),
               ("min_clearance", "min clearance m"), ("time_in_danger", "in danger s"), ("jerk_rms", "jerk m/s³"),
               ("curvature_mean", "curvature 1/m")]


def write_report(report: ChallengeReport, out: Path, desc: WorldDescription, optimal: np.ndarray, goal: Pose2D,
                 robot_radius: float) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for r in report.runs:
        path = out / f"run_{r.run}.csv"
        np.savetxt(path, r.trajectory, delimiter=",", header=",".join(TRAJ_COLUMNS), comments="", fmt="%.6f")
        report.files[f"run_{r.run}_csv"] = path
    png = _plot(report, out / "trajectories.png", desc, optimal, goal, robot_radius)
    if png is not None:
        report.files["png"] = png
    for name, text in (("json", json.dumps(report.to_dict(), indent=2) + "\n"), ("md", markdown(report)),
                       ("html", page(report, png))):
        report.files[name] = out / f"report.{name}"
        report.files[name].write_text(text, encoding="utf-8")


def _plot(report: ChallengeReport, path: Path, desc: WorldDescription, optimal: np.ndarray, goal: Pose2D,
          robot_radius: float) -> Path | None:
    data = RunData(time_limit=float(report.config["time_limit"]), grid=rasterize_world(desc, resolution=0.05))
    opt = np.column_stack([np.zeros(len(optimal)), optimal, np.zeros(len(optimal))])
    data.traj = {"optimal": opt, **{f"run {r.run}": r.trajectory for r in report.runs}}
    data.radius = dict.fromkeys(data.traj, robot_radius)
    data.tasks = {"goal": TaskRecord("goal", "optimal", "go_to", "", {"goal": goal})}
    data.collisions = [{"robot": f"run {r.run}", "t": r.score.first_collision_time} for r in report.runs
                       if r.score.first_collision_time is not None]
    return save_plot(data, path)


def _fmt(v: Any) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    if isinstance(v, float):
        return f"{v:.3f}"
    return str(v)


def _rows(report: ChallengeReport) -> list[list[str]]:
    return [[_fmt(r.to_dict()[k]) for k, _ in RUN_COLUMNS] for r in report.runs]


def _headline(report: ChallengeReport) -> str:
    s = report.summary
    return (f"score {_fmt(s['score']['mean'])} ± {_fmt(s['score']['std'])} (BARN, 0.125–0.5 on success), "
            f"success rate {s['success_rate']:.0%} ({s['successes']}/{s['runs']}), T_opt {_fmt(s['t_opt'])} s, "
            f"rubric {report.rubric.earned:g}/{report.rubric.total:g} points")


def markdown(report: ChallengeReport) -> str:
    lines = [f"# Challenge {report.challenge}: `{report.contestant}`", "", _headline(report), "",
             "| " + " | ".join(h for _, h in RUN_COLUMNS) + " |", "|" + "---|" * len(RUN_COLUMNS)]
    lines += ["| " + " | ".join(row) + " |" for row in _rows(report)]
    lines += ["", "| run | reason |", "|---|---|"] + [f"| {r.run} | {r.reason} |" for r in report.runs]
    lines += ["", f"## {report.rubric.title}: {report.rubric.earned:g}/{report.rubric.total:g}", "",
              "| item | result | measured | expected | points |", "|---|---|---|---|---|"]
    lines += [f"| {i.description} | {'pass' if i.passed else '**FAIL**'} | {i.measured} | {i.expected} | "
              f"{i.earned:g}/{i.points:g} |" for i in report.rubric.items]
    lines += ["", "![trajectories](trajectories.png)", ""]
    return "\n".join(lines)


def page(report: ChallengeReport, png: Path | None) -> str:
    e = html.escape
    table = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>" for row in _rows(report))
    reasons = "".join(f"<li>run {r.run}: <b>{e(r.outcome.value)}</b> — {e(r.reason)}</li>" for r in report.runs)
    rubric = "".join(f"<tr class={'pass' if i.passed else 'fail'}><td>{e(i.description)}</td><td>"
                     f"{'pass' if i.passed else 'FAIL'}</td><td>{e(i.measured)}</td><td>{e(i.expected)}</td>"
                     f"<td>{i.earned:g}/{i.points:g}</td></tr>" for i in report.rubric.items)
    img = ""
    if png is not None:
        data = base64.b64encode(png.read_bytes()).decode()
        img = (f'<h2>Trajectories</h2><p>red: optimal path; then one colour per run.</p>'
               f'<img alt="trajectories" src="data:image/png;base64,{data}">')
    head = "".join(f"<th>{e(h)}</th>" for _, h in RUN_COLUMNS)
    return f"""<!doctype html><html><head><meta charset="utf-8"><title>{e(report.challenge)}</title><style>
body{{font-family:sans-serif;margin:2em}} table{{border-collapse:collapse}} td,th{{border:1px solid #ccc;
padding:3px 8px;text-align:right}} tr.fail td{{background:#fdd}} tr.pass td{{background:#efe}} img{{max-width:100%}}
</style></head><body><h1>Challenge {e(report.challenge)}</h1><p>contestant <code>{e(report.contestant)}</code></p>
<p>{e(_headline(report))}</p><h2>Runs</h2><table><tr>{head}</tr>{table}</table><ul>{reasons}</ul>
<h2>{e(report.rubric.title)}: {report.rubric.earned:g}/{report.rubric.total:g}</h2><table><tr><th>item</th>
<th>result</th><th>measured</th><th>expected</th><th>points</th></tr>{rubric}</table>{img}</body></html>
"""
