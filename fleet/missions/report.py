"""A run's reports: report.json (every metric and assertion), junit.xml (one test case per assertion),
report.md (for people).

report.json is deterministic — the same mission file and seed give the same bytes — except its `wall`
section (wall-clock time, real-time factor), which every comparison ignores (see `comparable`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any
from xml.etree import ElementTree as ET

import numpy as np

from fleet.missions.schema import Mission
from fleet.missions.types import AssertionResult, RunData, clean

WALL = "wall"
SETUP_ERRORS = ("load", "crash")  # the run never started or broke: the mission file or setup is at fault


def build_report(m: Mission, source: str, data: RunData, results: list[AssertionResult], channels: dict[str, int],
                 wall_s: float, recorded: bool) -> dict[str, Any]:
    """`channels`: messages published per topic (to the MCAP file when `recorded`, else to a live view only)."""
    return clean({
        "mission": m.name, "description": m.description, "source": source, "world": Path(m.world).stem,
        "seed": m.seed, "time_limit": m.time_limit, "end_time": data.end_time, "ended_because": data.ended_because,
        "passed": all(r.passed for r in results),
        "assertions": [r.to_dict() for r in results],
        "metrics": _metrics(data),
        "tasks": {k: {"robot": r.robot, "type": r.type, "state": r.state, "reason": r.reason, "started": r.started,
                      "finished": r.finished, "progress": r.progress} for k, r in data.tasks.items()},
        "behaviours": {k: {kk: v for kk, v in b.items() if kk != "id"} for k, b in data.behaviours.items()},
        "slam": data.slam,
        "timeline": data.scripted,
        "recording": {"file": "recording.mcap" if recorded else None, "channels": channels},
        **({"agents": {n: {k: v for k, v in a.items() if k != "output"} for n, a in data.agents.items()}}
           if data.agents else {}),
        WALL: {"wall_s": round(wall_s, 3),
               "real_time_factor": round(data.end_time / wall_s, 2) if wall_s > 0 else None,
               **({"agent_output": {n: a["output"] for n, a in data.agents.items()}} if data.agents else {})},
    })


def _metrics(data: RunData) -> dict[str, Any]:
    robots = {}
    for name, tr in data.traj.items():
        steps = np.hypot(*np.diff(tr[:, 1:3], axis=0).T) if len(tr) > 1 else np.zeros(0)
        robots[name] = {"path_length_m": float(steps.sum()),
                        "final_pose": {"x": float(tr[-1, 1]), "y": float(tr[-1, 2]), "yaw": float(tr[-1, 3])},
                        "min_static_clearance_m": data.min_static_clearance.get(name, math.inf),
                        "collisions": sum(1 for c in data.collisions if c["robot"] == name),
                        **({"killed_at": data.removed[name]} if name in data.removed else {})}
    return {"robots": robots, "collisions": len(data.collisions), "min_robot_gap_m": data.min_robot_gap,
            "events": data.event_counts}


def comparable(report: dict[str, Any]) -> dict[str, Any]:
    """The report without its wall-clock section: what two runs of one file and seed must agree on."""
    return {k: v for k, v in report.items() if k != WALL}


def write_reports(report: dict[str, Any], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    (out / "junit.xml").write_text(junit_xml([report]), encoding="utf-8")
    (out / "report.md").write_text(markdown(report), encoding="utf-8")


def junit_xml(reports: list[dict[str, Any]]) -> str:
    """One <testsuite> per run, one <testcase> per assertion; a failure's message carries the numbers."""
    suites = ET.Element("testsuites")
    for r in reports:
        label = f"{r['mission']}[seed={r['seed']}]"
        cases = r.get("assertions", [])
        errors = sum(not c["passed"] and c["type"] in SETUP_ERRORS for c in cases)
        suite = ET.SubElement(suites, "testsuite", name=label, tests=str(len(cases)),
                              failures=str(sum(not c["passed"] for c in cases) - errors), errors=str(errors),
                              time=f"{r.get(WALL, {}).get('wall_s', 0.0):.3f}")
        for c in cases:
            case = ET.SubElement(suite, "testcase", classname=f"missions.{r['mission']}", name=c["name"])
            if not c["passed"]:
                # A run that could not be set up (bad file, missing model) is an <error>, not a <failure>.
                tag = "error" if c["type"] in SETUP_ERRORS else "failure"
                fail = ET.SubElement(case, tag, message=c["message"], type=c["type"])
                fail.text = f"measured: {c['measured']}\nexpected: {c['expected']}\n{c['message']}"
        ET.SubElement(suite, "system-out").text = f"sim time {r['end_time']} s ({r['ended_because']})"
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def markdown(r: dict[str, Any]) -> str:
    lines = [f"# Mission {r['mission']}: {'PASS' if r['passed'] else 'FAIL'}", "",
             r["description"] or "", "",
             f"World `{r['world']}`, seed {r['seed']}, sim time {r['end_time']:.1f} s of {r['time_limit']:g} s "
             f"({r['ended_because']}); wall {r[WALL]['wall_s']:.1f} s.", "",
             "| assertion | result | measured | expected |", "|---|---|---|---|"]
    for c in r["assertions"]:
        lines.append(f"| {c['name']} | {'pass' if c['passed'] else '**FAIL**'} | {c['measured']} | {c['expected']} |")
    lines += ["", "| robot | path m | min clearance m | collisions | final pose |", "|---|---|---|---|---|"]
    for n, m in r["metrics"]["robots"].items():
        p = m["final_pose"]
        lines.append(f"| {n} | {m['path_length_m']:.2f} | {m['min_static_clearance_m']} | {m['collisions']} | "
                     f"({p['x']:.2f}, {p['y']:.2f}, {p['yaw']:.2f}) |")
    if r["tasks"]:
        lines += ["", "| task | robot | type | state | finished |", "|---|---|---|---|---|"]
        lines += [f"| {k} | {t['robot']} | {t['type']} | {t['state']} {t['reason']} | {t['finished']} |"
                  for k, t in r["tasks"].items()]
    if r["timeline"]:
        lines += ["", "Timeline:", ""] + [f"- t={e['t']:g} s: {e['what']} — {e['result']}" for e in r["timeline"]]
    failed = [c for c in r["assertions"] if not c["passed"]]
    if failed:
        lines += ["", "Failures:", ""] + [f"- **{c['name']}**: {c['message']}" for c in failed]
    lines += ["", "Files: report.json, junit.xml, trajectories.png, mission.yaml"
              + (", recording.mcap" if r["recording"]["file"] else ""), ""]
    return "\n".join(lines)
