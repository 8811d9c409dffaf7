"""`fleetnav run | validate | replay | diff` exit codes and outputs, and the pytest plugin (`--missions`)."""

import json
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

from typer.testing import CliRunner

from fleetnav.cli import app

DATA = Path(__file__).resolve().parent / "data"
FAILING, QUICK = DATA / "failing_mission.yaml", DATA / "quick_mission.yaml"
runner = CliRunner()


def test_failing_assertion_exits_non_zero_with_a_junit_failure_carrying_numbers(tmp_path):
    res = runner.invoke(app, ["run", str(FAILING), str(QUICK), "--out", str(tmp_path)])
    assert res.exit_code == 1, res.output
    assert "FAILED too_fast" in res.output
    suites = ET.parse(tmp_path / "junit.xml").getroot()
    failures = suites.findall(".//failure")
    assert len(failures) == 1
    msg = failures[0].get("message") or ""
    assert "closest" in msg and "required within 0.3 m by t=3 s" in msg
    closest = float(msg.split("closest ")[1].split(" m")[0])
    assert 9.0 < closest < 12.5  # ~12.7 m from the start to the goal, minus what 3 s of driving covers
    suite = suites.find(".//testsuite[@name='quick_mission[seed=0]']")
    assert suite is not None and suite.get("failures") == "0"


def test_all_passing_exits_zero_and_repeat_reports_the_pass_rate(tmp_path):
    res = runner.invoke(app, ["run", str(QUICK), "--repeat", "2", "--seed", "5", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "summary.json").read_text())["quick_mission"]
    assert summary["runs"] == 2 and summary["seeds"] == [5, 6] and summary["pass_rate"] == 1.0
    assert summary["assertions"]["hops"]["pass_rate"] == 1.0
    assert summary["assertions"]["hops"]["min"] <= summary["assertions"]["hops"]["max"]
    assert (tmp_path / "quick_mission" / "seed-5" / "report.json").is_file()
    assert (tmp_path / "quick_mission" / "seed-6" / "report.json").is_file()


def test_validate_points_at_file_line_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(QUICK.read_text().replace("time_limit: 6", "time_limit: -6"))
    res = runner.invoke(app, ["validate", str(QUICK), str(bad)])
    assert res.exit_code == 2
    assert f"{bad}:5: field 'time_limit'" in res.output  # line 5: the file opens with a comment
    assert f"ok    {QUICK}" in res.output


def test_run_of_an_invalid_file_is_an_input_error(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(QUICK.read_text().replace("robot: r1, type", "robot: r2, type"))
    res = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "unknown robot 'r2'" in res.output


def test_replay_and_diff_commands(tmp_path):
    rec = tmp_path / "rec.yaml"
    rec.write_text(QUICK.read_text().replace("recording: {enabled: false}", "recording: {scans: false}"))
    assert runner.invoke(app, ["run", str(rec), "--out", str(tmp_path / "a")]).exit_code == 0
    assert runner.invoke(app, ["run", str(rec), "--out", str(tmp_path / "b")]).exit_code == 0
    res = runner.invoke(app, ["replay", str(tmp_path / "a" / "quick_mission" / "recording.mcap")])
    assert res.exit_code == 0 and "max divergence" in res.output
    res = runner.invoke(app, ["diff", str(tmp_path / "a" / "quick_mission"), str(tmp_path / "b" / "quick_mission")])
    assert res.exit_code == 0 and "identical" in res.output
    res = runner.invoke(app, ["replay", str(tmp_path / "nope.mcap")])
    assert res.exit_code == 2


def test_pytest_plugin_runs_missions_as_tests(tmp_path):
    args = ["-p", "no:cacheprovider", "--missions", str(QUICK),  # the plugin comes from the pytest11 entry point
            "--missions", str(FAILING), "--missions-out", str(tmp_path / "runs"), "--junitxml", str(tmp_path / "j.xml"),
            "-q", "--rootdir", str(tmp_path), str(tmp_path)]
    res = subprocess.run([sys.executable, "-m", "pytest", *args], capture_output=True, text=True, cwd=tmp_path,
                         timeout=120)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "1 failed, 1 passed" in res.stdout
    assert "too_fast: r1" in res.stdout
    cases = ET.parse(tmp_path / "j.xml").getroot().findall(".//testcase")
    props = {p.get("name"): p.get("value") or "" for c in cases for p in c.findall(".//property")}
    assert props["hops"].startswith("pass") and props["too_fast"].startswith("FAIL")


def test_a_missing_mission_is_one_line_and_exit_2_and_shipped_names_resolve(tmp_path):
    from fleetnav.cmd_missions import mission_file
    from sim.resources import shipped

    res = runner.invoke(app, ["run", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "no mission file" in lines[0] and "arena_navigation" in lines[0]
    assert mission_file("arena_navigation") == shipped("missions", "arena_navigation.yaml")
    assert mission_file(str(QUICK)) == QUICK
