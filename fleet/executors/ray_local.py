"""A Ray cluster on this machine for tests, benchmarks and trying things out: `ray start --head` on 127.0.0.1
with N worker CPUs, in a process group of its own, so stopping it stops exactly the processes it started
(never another Ray on the machine, as `ray stop` would)."""

from __future__ import annotations

import contextlib
import logging
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

# Set before Ray is imported (it reads them once): stay on loopback, send no usage statistics, and say the
# token mode explicitly so this driver and the cluster agree (the token lives in ~/.ray/auth_token).
LOOPBACK_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0", "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "token"}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def local_cluster(cpus: int = 2, timeout_s: float = 90.0, connect: bool = True) -> Iterator[str]:
    """Yields the cluster's address ("127.0.0.1:<port>"); with `connect`, this process is its driver."""
    os.environ.update(LOOPBACK_ENV)
    import ray
    from ray._private import ray_constants

    if ray_constants.ENABLE_RAY_CLUSTER:  # Ray was imported before LOOPBACK_ENV: it would leave loopback
        raise RuntimeError("set RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0 before importing ray")
    port = free_port()
    temp = tempfile.mkdtemp(prefix="rt", dir="/tmp")  # short: Ray's socket paths must fit in 107 bytes
    _ensure_token()
    cmd = [str(Path(sys.executable).with_name("ray")), "start", "--head", f"--port={port}", f"--num-cpus={cpus}",
           "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp}"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, env=os.environ | LOOPBACK_ENV)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
        if proc.returncode != 0:
            raise RuntimeError(f"ray start failed:\n{out}")
        address = f"127.0.0.1:{port}"
        if connect:
            ray.init(address=address, log_to_driver=False, logging_level=logging.WARNING)
        yield address
    finally:
        with contextlib.suppress(Exception):
            ray.shutdown()
        _kill_group(proc.pid)
        shutil.rmtree(temp, ignore_errors=True)


def _ensure_token() -> None:
    """`ray start` refuses to start in token mode without a token, and a fresh machine has none (`ray.init()`
    would write ~/.ray/auth_token, `ray start` does not). Unless the user configured one, give this process's
    clusters one token for the process's life (the driver caches the token it first reads)."""
    if os.environ.get("RAY_AUTH_TOKEN") or os.environ.get("RAY_AUTH_TOKEN_PATH"):
        return
    if (Path.home() / ".ray" / "auth_token").is_file():
        return
    os.environ["RAY_AUTH_TOKEN"] = secrets.token_hex(32)  # inherited by `ray start` and its daemons


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
    """PIDs of Ray workers running a task named `title` (Ray titles a busy worker `ray::<task>`)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            with contextlib.suppress(OSError):
                if (d / "cmdline").read_bytes().startswith(f"ray::{title}".encode()):
                    pids.append(int(d.name))
    return pids
