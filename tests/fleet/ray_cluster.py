"""A throwaway Ray cluster on 127.0.0.1 for tests: `ray start --head` with two worker CPUs in its own process
group (so the test stops exactly the processes it started, never another Ray on the machine)."""

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0",  # loopback, no telemetry
       "RAY_AUTH_MODE": "token"}  # explicit, so the cluster and this driver agree (token in ~/.ray/auth_token)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def ray_cluster(cpus: int = 2, timeout_s: float = 90.0):
    """Yields the cluster's address; the driver in this process is connected to it."""
    os.environ.update(ENV)
    import ray
    from ray._private import ray_constants

    if ray_constants.ENABLE_RAY_CLUSTER:  # Ray was imported before ENV was set: it would leave loopback and hang
        raise RuntimeError("set RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 before importing ray")
    port = free_port()
    temp = tempfile.mkdtemp(prefix="rt", dir="/tmp")  # short: Ray's socket paths must fit in 107 bytes
    ray_bin = str(Path(sys.executable).with_name("ray"))
    cmd = [ray_bin, "start", "--head", f"--port={port}", f"--num-cpus={cpus}", "--include-dashboard=false",
           "--disable-usage-stats", f"--temp-dir={temp}"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, env=os.environ | ENV)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
        if proc.returncode != 0:
            raise RuntimeError(f"ray start failed:\n{out}")
        address = f"127.0.0.1:{port}"
        ray.init(address=address, log_to_driver=False, logging_level="warning")
        yield address
    finally:
        with contextlib.suppress(Exception):
            ray.shutdown()
        _kill_group(proc.pid)
        shutil.rmtree(temp, ignore_errors=True)


def _kill_group(pgid: int) -> None:
    """Ray's daemons keep the process group of the `ray start` that launched them."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pgid, sig)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            try:
                os.killpg(pgid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.2)


def task_pids(title: str) -> list[int]:
    """PIDs of Ray workers running a task named `title` (Ray sets a worker's title to `ray::<task>`)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            with contextlib.suppress(OSError):
                if (d / "cmdline").read_bytes().startswith(f"ray::{title}".encode()):
                    pids.append(int(d.name))
    return pids
