"""The local executors against jobs whose outcome is known: values and files come back in job order, a worker
killed under a job costs that job exactly one retry, a job past its time limit is stopped on the worker, a
raising job is an error result, and the retry budget is bounded."""

import os
import signal
import time
from pathlib import Path

import pytest

from fleet.executors import InlineExecutor, Job, JobState, PoolExecutor, make_executor
from sim.errors import FleetError


def square_and_write(x, scratch: Path):
    (scratch / "sub").mkdir()
    (scratch / "sub" / "value.txt").write_text(str(x * x))
    return x * x


def die_once(marker: str, scratch: Path):
    """Kill this worker (SIGKILL, as the OOM killer would) the first time; succeed the second."""
    m = Path(marker)
    if not m.exists():
        m.write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return os.getpid()


def always_die(_: object, scratch: Path):
    os.kill(os.getpid(), signal.SIGKILL)


def sleep_for(seconds: float, scratch: Path):
    time.sleep(seconds)
    return seconds


def boom(_: object, scratch: Path):
    raise ValueError("bad input 42")


def test_pool_returns_values_and_files_in_job_order(tmp_path):
    jobs = [Job(f"j{x}", square_and_write, x, str(tmp_path / f"j{x}")) for x in range(5)]
    events = []
    res = PoolExecutor(2).run(jobs, on_event=lambda i, s, r: events.append((i, s)))
    assert [r.value for r in res] == [0, 1, 4, 9, 16]
    assert [r.state for r in res] == [JobState.DONE] * 5
    for x in range(5):
        assert (tmp_path / f"j{x}" / "sub" / "value.txt").read_text() == str(x * x)
    assert sorted(i for i, s in events if s is JobState.DONE) == list(range(5))
    assert len({r.worker for r in res}) <= 2


def test_a_killed_worker_costs_its_job_one_retry(tmp_path):
    marker = tmp_path / "died"
    jobs = [Job("dies", die_once, str(marker)), Job("fine", square_and_write, 3, str(tmp_path / "fine"))]
    res = PoolExecutor(2, retries=2).run(jobs)
    assert res[0].state is JobState.DONE and res[0].attempts == 2
    assert res[0].value != int(marker.read_text())  # a fresh worker ran it
    assert res[1].state is JobState.DONE and res[1].attempts == 1 and res[1].value == 9


def test_the_retry_budget_is_bounded(tmp_path):
    res = PoolExecutor(1, retries=1).run([Job("always", always_die, None), Job("next", square_and_write, 2)])
    assert res[0].state is JobState.LOST and res[0].attempts == 2
    assert res[1].state is JobState.DONE and res[1].value == 4  # the pool carried on with a new worker


@pytest.mark.parametrize("executor", [InlineExecutor(), PoolExecutor(2)], ids=["inline", "pool"])
def test_time_limit_and_errors_end_the_job_on_the_worker(executor):
    t0 = time.monotonic()
    res = executor.run([Job("hang", sleep_for, 30.0, time_limit_s=0.5), Job("raise", boom, None),
                        Job("quick", sleep_for, 0.01, time_limit_s=5.0)])
    assert time.monotonic() - t0 < 20.0
    assert res[0].state is JobState.TIMEOUT and "0.5 s" in res[0].error
    assert res[1].state is JobState.ERROR and "bad input 42" in res[1].error
    assert res[2].state is JobState.DONE and res[2].value == 0.01


def test_executor_names_and_options_are_checked():
    with pytest.raises(FleetError, match="executors: local, ray"):
        make_executor("dask")
    with pytest.raises(FleetError, match="--ray-address needs --executor ray"):
        make_executor("local", ray_address="auto")
    assert isinstance(make_executor("local", jobs=1), InlineExecutor)
    assert isinstance(make_executor("local", jobs=3), PoolExecutor)


def test_executor_ray_without_ray_says_how_to_install(tmp_path):
    """`fleetnav run --executor ray` in an environment without Ray: exit 2 and the pip command, no traceback."""
    import subprocess
    import sys

    quick = Path(__file__).resolve().parent / "data" / "quick_mission.yaml"
    code = ("import sys; sys.modules['ray'] = None\n"  # makes `import ray` fail as if it were not installed
            "from fleetnav.cli import app\n"
            f"app(['run', {str(quick)!r}, '--executor', 'ray', '--out', {str(tmp_path)!r}])")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "pip install 'fleetnav[ray]'" in res.stderr and "Traceback" not in res.stderr


def test_ctrl_c_cancels_the_sweep_and_writes_the_partial_summary(tmp_path):
    """SIGINT to `fleetnav run -j 2` (40 runs) once the first run has finished: exit 130, the finished runs are in
    junit.xml and summary.json, the rest are not."""
    import json
    import subprocess
    import sys
    from xml.etree import ElementTree as ET

    quick = Path(__file__).resolve().parent / "data" / "quick_mission.yaml"
    out = tmp_path / "runs"
    code = "from fleetnav.cli import app; app()"
    proc = subprocess.Popen([sys.executable, "-c", code, "run", str(quick), "--repeat", "40", "-j", "2", "--out",
                             str(out), "--no-record"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(out.rglob("report.json")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stdout + stderr
    assert "canceled:" in stderr
    finished = sorted(p.parent.name for p in out.rglob("report.json"))
    assert 1 <= len(finished) < 40  # 40 runs: margin for a poll loop descheduled on a loaded machine
    summary = json.loads((out / "summary.json").read_text())
    assert summary["quick_mission"]["runs"] == len(finished)
    suites = ET.parse(out / "junit.xml").getroot().findall("testsuite")
    names = sorted(str(s.get("name")) for s in suites)
    assert names == sorted(f"quick_mission[seed={n.split('-')[1]}]" for n in finished)


def test_run_map_puts_a_plain_loop_on_an_executor():
    import math

    from fleet.executors import run_map

    seen = []
    res = run_map(math.factorial, [5, 3, 0], jobs=2, show_progress=False, on_result=lambda r: seen.append(r.index))
    assert [r.value for r in res] == [120, 6, 1] and sorted(seen) == [0, 1, 2]
    assert [r.key for r in res] == ["5", "3", "0"]
