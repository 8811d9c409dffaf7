"""A leaderboard file across agents: one JSON file, one entry per (challenge, contestant), latest run wins.

Ranked per challenge by mean BARN score, then success rate, then mean time; rendered as Markdown.
"""

from __future__ import annotations

import json
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fleet.grading.types import ChallengeReport
from sim.errors import ErrorCode, FleetError

VERSION = 1


def load(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        entries = doc["entries"]
    except (ValueError, KeyError, TypeError) as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{path} is not a fleetnav leaderboard: {exc}",
                         "give another file, or delete this one to start afresh") from exc
    return list(entries)


def entry(report: ChallengeReport, name: str | None = None) -> dict[str, Any]:
    s = report.summary
    return {"challenge": report.challenge, "contestant": name or report.contestant, "command": report.contestant,
            "runs": s["runs"], "success_rate": s["success_rate"], "score_mean": s["score"]["mean"],
            "score_std": s["score"]["std"], "time_mean": s["time"]["mean"], "spl_mean": s["spl"]["mean"],
            "collisions": sum(r.score.collisions for r in report.runs), "rubric": report.rubric.earned,
            "rubric_total": report.rubric.total, "date": datetime.now(UTC).isoformat(timespec="seconds"),
            "report": str(report.files.get("json", ""))}


def add(path: Path, report: ChallengeReport, name: str | None = None) -> list[dict[str, Any]]:
    """Record `report` under `name` (default: the contestant command), replacing that contestant's entry."""
    new = entry(report, name)
    entries = [e for e in load(path) if (e["challenge"], e["contestant"]) != (new["challenge"], new["contestant"])]
    entries.append(new)
    entries = ranked(entries)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"version": VERSION, "entries": entries}, indent=2) + "\n", encoding="utf-8")
    return entries


def ranked(entries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    def key(e: dict[str, Any]) -> tuple[str, float, float, float]:
        t = e.get("time_mean")
        return (e["challenge"], -(e.get("score_mean") or 0.0), -(e.get("success_rate") or 0.0),
                t if t is not None and math.isfinite(t) else math.inf)

    return sorted(entries, key=key)


def markdown(entries: list[dict[str, Any]], challenge: str | None = None) -> str:
    lines: list[str] = []
    for ch in sorted({e["challenge"] for e in entries if challenge in (None, e["challenge"])}):
        lines += [f"## {ch}", "", "| rank | contestant | score | ± | success | time s | SPL | collisions | rubric |",
                  "|---|---|---|---|---|---|---|---|---|"]
        rows = [e for e in ranked(entries) if e["challenge"] == ch]
        for k, e in enumerate(rows, 1):
            lines.append(f"| {k} | `{e['contestant']}` | {_f(e['score_mean'])} | {_f(e['score_std'])} | "
                         f"{e['success_rate']:.0%} | {_f(e['time_mean'], 2)} | {_f(e['spl_mean'])} | "
                         f"{e['collisions']} | {e['rubric']:g}/{e['rubric_total']:g} |")
        lines.append("")
    return "\n".join(lines) if lines else "(no entries)\n"


def _f(v: float | None, digits: int = 3) -> str:
    return "—" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"
