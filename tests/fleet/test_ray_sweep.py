"""Missions on a real two-worker Ray cluster on loopback (started and stopped here): three missions × two seeds
give byte-for-byte the files of the local executor (report.json minus its wall-clock section, JUnit minus its
time attributes, MCAP, mission.yaml); a worker killed under a run costs that run one retry and the report is
the one a clean run writes."""

import json
import os
import re
import signal
import threading
import time
from pathlib import Path

import pytest

from fleet.executors.ray_local import LOOPBACK_ENV

os.environ.update(LOOPBACK_ENV)  # before Ray is imported: it reads them once (loopback only, no usage statistics)
ray = pytest.importorskip("ray", reason="Ray is not installed (pip install 'fleetnav[ray]'; the dev extra has it)")

from fleet.executors import JobState, PoolExecutor  # noqa: E402
from fleet.executors.ray_exec import RayExecutor  # noqa: E402
from fleet.executors.ray_local import local_cluster, task_pids  # noqa: E402
from fleet.missions.batch import as_outcome, mission_jobs, plan_runs, run_batch, write_batch_outputs  # noqa: E402
from fleet.missions.report import comparable  # noqa: E402

MISSIONS = Path(__file__).resolve().parents[2] / "configs" / "missions"
PATHS = [str(MISSIONS / f"{n}.yaml") for n in ("arena_navigation", "coverage", "failure_injection")]


@pytest.fixture(scope="module")
def cluster():
    with local_cluster(cpus=2) as address:
        yield address


@pytest.fixture(scope="module")
def local(tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    outcomes = run_batch(plan_runs(PATHS, out, 5, 2), jobs=2, show_progress=False)
    write_batch_outputs(outcomes, out)
    return out, outcomes


def files(root: Path) -> dict[str, bytes]:
    """Every output file, with the wall-clock figures taken out (report.md prints the wall time)."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        if not p.is_file() or p.name == "report.md":
            continue
        data = p.read_bytes()
        if p.name == "report.json":
            data = json.dumps(comparable(json.loads(data)), indent=2).encode()
        elif p.name == "junit.xml":
            data = re.sub(rb' time="[0-9.]+"', b"", data)
        out[rel] = data
    return out


def test_ray_sweep_matches_local_byte_for_byte(cluster, local, tmp_path):
    local_out, local_outcomes = local
    outcomes = run_batch(plan_runs(PATHS, tmp_path, 5, 2), show_progress=False, executor="ray",
                         ray_address=cluster)
    write_batch_outputs(outcomes, tmp_path)
    assert [(o.mission, o.seed, o.passed) for o in outcomes] == \
        [(o.mission, o.seed, o.passed) for o in local_outcomes]
    assert len(outcomes) == 6 and all(o.passed for o in outcomes)
    a, b = files(local_out), files(tmp_path)
    assert sorted(a) == sorted(b)
    assert sum(name.endswith("recording.mcap") for name in a) == 6
    different = [name for name in a if a[name] != b[name]]
    assert not different, different
    workers = {o.report["seed"] for o in outcomes}
    assert workers == {5, 6}


def test_a_worker_killed_mid_run_costs_one_retry(cluster, local, tmp_path):
    reqs = plan_runs(PATHS, tmp_path, 5, 1, record=False)
    killed: list[int] = []
    stop = threading.Event()

    def killer() -> None:  # the first worker seen running a run is killed, once
        while not stop.is_set() and not killed:
            pids = task_pids("fleetnav_job")
            if pids:
                time.sleep(0.5)  # well inside the run (each takes seconds)
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.05)

    t = threading.Thread(target=killer, daemon=True)
    t.start()
    try:
        results = RayExecutor(cluster, retries=2).run(mission_jobs(reqs, run_timeout=120.0))
    finally:
        stop.set()
        t.join(5.0)
    assert len(killed) == 1
    assert sorted(r.attempts for r in results) == [1, 1, 2]
    assert all(r.state is JobState.DONE for r in results)
    assert str(killed[0]) not in {r.worker.split(":")[1] for r in results}
    local_reports = {(o.mission, o.seed): comparable(o.report) for o in local[1]}
    for req, res in zip(reqs, results, strict=True):
        o = as_outcome(req, res)
        assert o.passed
        expected = dict(local_reports[(o.mission, o.seed)])
        got = comparable(json.loads((Path(req.out_dir) / "report.json").read_text()))
        # recorded vs not: the recording section differs by design, the rest must not
        expected.pop("recording"), got.pop("recording")
        assert got == expected


def test_pool_and_ray_share_the_retry_rules():
    assert PoolExecutor(2, retries=3).retries == RayExecutor(None, retries=3).retries == 3


def test_pytest_plugin_runs_missions_on_the_cluster(cluster, tmp_path):
    import subprocess
    import sys

    data = Path(__file__).resolve().parent / "data"
    args = ["-p", "no:cacheprovider", "--missions", str(data / "quick_mission.yaml"), "--missions",
            str(data / "failing_mission.yaml"), "--missions-out", str(tmp_path / "runs"), "--missions-executor", "ray",
            "--missions-ray-address", cluster, "-q", "--rootdir", str(tmp_path), str(tmp_path)]
    res = subprocess.run([sys.executable, "-m", "pytest", *args], capture_output=True, text=True, cwd=tmp_path,
                         timeout=180, env=os.environ | LOOPBACK_ENV)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "1 failed, 1 passed" in res.stdout
    assert "too_fast: r1" in res.stdout
    reports = sorted((tmp_path / "runs").rglob("report.json"))
    assert [json.loads(p.read_text())["passed"] for p in reports] == [False, True]  # failing_mission, quick_mission


def test_challenge_runs_on_the_cluster_match_runs_in_turn(cluster, tmp_path):
    from fleet.grading import run_challenge

    here = run_challenge("cluttered_1", controller="builtin:pure_pursuit", runs=2, out_dir=tmp_path / "here")
    there = run_challenge("cluttered_1", controller="builtin:pure_pursuit", runs=2, out_dir=tmp_path / "ray",
                          executor=RayExecutor(cluster))
    assert [r.seed for r in there.runs] == [r.seed for r in here.runs] == [here.runs[0].seed, here.runs[0].seed + 1]
    for a, b in zip(here.runs, there.runs, strict=True):
        assert a.outcome == b.outcome and a.score == b.score
        assert a.trajectory.shape == b.trajectory.shape and (a.trajectory == b.trajectory).all()


def test_a_hung_run_is_stopped_on_its_ray_worker_by_its_own_limit(cluster):
    """A job that would sleep 60 s with a 1 s limit: SIGALRM in the Ray worker ends it as TIMEOUT; the next
    job on the cluster runs normally (the worker survived)."""
    from fleet.executors import Job
    from fleet.executors.mapping import call_one

    t0 = time.monotonic()
    res = RayExecutor(cluster).run([Job("hang", call_one, (time.sleep, 60.0), time_limit_s=1.0),
                                    Job("ok", call_one, (abs, -3), time_limit_s=30.0)])
    assert time.monotonic() - t0 < 45.0
    assert res[0].state is JobState.TIMEOUT and "1 s" in res[0].error
    assert res[1].state is JobState.DONE and res[1].value == 3
