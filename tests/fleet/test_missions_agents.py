"""External agents in a mission: a real process (examples/wall_follower.py) drives a robot over the Zenoh API
in lock-step, so the run is deterministic; an agent that dies is a failed run that says why."""

from pathlib import Path

from fleet.missions.batch import RunRequest, run_file

DATA = Path(__file__).resolve().parent / "data"


def test_lockstep_agent_drives_the_robot_deterministically(tmp_path):
    runs = [run_file(RunRequest(str(DATA / "agent_wall_follower.yaml"), None, str(tmp_path / k))) for k in "ab"]
    a, b = (r.report for r in runs)
    assert a["passed"], [x["message"] for x in a["assertions"]]
    assert a["agents"] == {"wf": {"exit_code": 0, "stopped": False}}
    # the agent answers 60 ticks (6 s at 10 Hz), then leaves lock-step; the run ends at that tick
    assert a["ended_because"] == "all tasks done" and a["end_time"] == 6.1
    assert a["metrics"]["robots"]["r1"]["path_length_m"] > 1.0  # it drove (0.4 m/s cruise)
    strip = {"wall"}
    assert {k: v for k, v in a.items() if k not in strip} == {k: v for k, v in b.items() if k not in strip}


def test_an_agent_that_dies_fails_the_run_with_its_exit_code(tmp_path):
    text = (DATA / "agent_wall_follower.yaml").read_text()
    start = text.index("      command:")
    end = text.index("recording:")
    path = tmp_path / "dying.yaml"
    path.write_text(text[:start] + '      command: [python, -c, "import sys; print(\'boom\'); sys.exit(3)"]\n'
                    + text[end:])
    out = run_file(RunRequest(str(path), None, str(tmp_path / "o")))
    assert not out.passed
    setup = out.report["assertions"][0]
    assert setup["name"] == "setup" and "agent wf exited (3) before joining lock-step: boom" in setup["message"]
