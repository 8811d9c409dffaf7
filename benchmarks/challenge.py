"""Navigation challenges: BARN score and success rate of fleetnav's builtin navigators on the generated arena set.

Each contestant is graded with fleet.grading.run_challenge exactly as `fleetnav challenge run` grades it
(kinematic fidelity, 10 Hz control, collision ends the run). Builtins: the navigator (guided Theta* plan →
controller → replan → recover) with each registered controller. Baseline, measured in the same run on the
same challenges: the reference contestant, examples/goal_seeker.py (a reactive goal seeker, the course's
"obstacle avoidance with goal seeking"), as a separate process over the Zenoh API in lock-step. The closed-form
ceiling is 0.5 (reaching the goal within 2·T_opt).

    .venv/bin/python benchmarks/challenge.py            # cluttered_1..5 + arena_course, 3 runs each
    .venv/bin/python benchmarks/challenge.py --quick    # cluttered_1, cluttered_5; 1 run each
    .venv/bin/python benchmarks/challenge.py --map-source prior  # the rule for known maps, for comparison

Every contestant runs under the challenge's `map_source` rule (default sensors: the builtins navigate on their
own lidar, and the goal seeker is refused the world's map, so it seeks the goal reactively) unless told.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

# The repo root instead of this script's folder: benchmarks/zenoh.py would shadow the zenoh package.
sys.path[0] = str(Path(__file__).resolve().parent.parent)

from fleet.grading import ChallengeReport, run_challenge  # noqa: E402
from fleet.grading.challenge import load_challenge  # noqa: E402
from planning import controller_names  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SEEKER = (f"python {ROOT / 'examples' / 'goal_seeker.py'} --connect {{connect}} --robot {{robot}} "
          "--goal {goal_x} {goal_y} --lockstep")


def grade(challenge: str, who: str, runs: int, out: Path, map_source: str | None) -> tuple[ChallengeReport, float]:
    t0 = time.perf_counter()
    agent, controller = (SEEKER, None) if who == "goal_seeker" else (None, f"builtin:{who}")
    ch = load_challenge(challenge)
    if map_source is not None:
        ch = ch.model_copy(update={"map_source": map_source})
    report = run_challenge(ch, agent=agent, controller=controller, runs=runs, out_dir=out / challenge / who)
    return report, time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--map-source", choices=("sensors", "prior", "both"), default=None,
                    help="the rule for every contestant (default: each challenge's own, sensors for the shipped "
                    "ones): what a builtin's navigator knows, and whether the goal seeker may ask for the map")
    ap.add_argument("--challenges", default=None, help="comma-separated names (default: all shipped)")
    ap.add_argument("--runs", type=int, default=None, help="runs per contestant (default 3, --quick 1)")
    ap.add_argument("--contestants", default=None, help="comma-separated: goal_seeker and/or builtin names")
    a = ap.parse_args()
    challenges = ["cluttered_1", "cluttered_5"] if a.quick else [f"cluttered_{k}" for k in range(1, 6)] + [
        "arena_course"]
    if a.challenges:
        challenges = a.challenges.split(",")
    runs = a.runs or (1 if a.quick else 3)
    contestants = a.contestants.split(",") if a.contestants else ["goal_seeker", *controller_names()]
    rule = a.map_source or "each challenge's own (" + ", ".join(
        sorted({load_challenge(c).map_source for c in challenges})) + ")"
    print(f"{len(challenges)} challenges × {runs} run(s); map_source: {rule}; baseline: "
          "goal_seeker (over Zenoh in lock-step)")
    print(f"{'challenge':14s} {'contestant':14s} {'success':>8s} {'score':>7s} {'±':>6s} {'T s':>7s} {'T_opt s':>8s} "
          f"{'SPL':>6s} {'min clr m':>9s} {'jerk':>6s} {'wall s':>7s}")
    totals: dict[str, list[float]] = {c: [] for c in contestants}
    rates: dict[str, list[float]] = {c: [] for c in contestants}
    with tempfile.TemporaryDirectory() as tmp:
        for ch in challenges:
            for who in contestants:
                rep, wall = grade(ch, who, runs, Path(tmp), a.map_source)
                s = rep.summary
                totals[who].append(s["score"]["mean"])
                rates[who].append(s["success_rate"])
                t = s["time"]["mean"]
                print(f"{ch:14s} {who:14s} {s['success_rate']:8.0%} {s['score']['mean']:7.3f} "
                      f"{s['score']['std']:6.3f} {t if t is not None else float('nan'):7.2f} {s['t_opt']:8.2f} "
                      f"{s['spl']['mean']:6.3f} {s['min_clearance']['min']:9.3f} {s['jerk_rms']['mean']:6.2f} "
                      f"{wall:7.1f}", flush=True)
                failed = [r for r in rep.runs if not r.score.success]
                for r in failed:
                    print(f"{'':14s} {'':14s}   run {r.run}: {r.outcome.value}: {r.reason[:90]}")
    print("\nmean over challenges (ceiling 0.5):")
    for who in contestants:
        print(f"  {who:14s} score {sum(totals[who]) / len(totals[who]):.3f}   "
              f"success {sum(rates[who]) / len(rates[who]):.0%}" + ("   (baseline)" if who == "goal_seeker" else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
