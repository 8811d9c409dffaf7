"""Executors for sweeps: a list of picklable jobs → one result per job, locally or on a Ray cluster.

    results = make_executor("ray", ray_address="auto").run(jobs, on_event=progress.event)

`local` is a process pool of `jobs` workers (or this process with `jobs=1`); `ray` needs the `fleetnav[ray]`
extra. Both retry a job whose worker died (up to `retries` times), hold each job to its time limit on the
worker, return the files a job wrote as data, and stop cleanly on Ctrl-C with what finished.
"""

from __future__ import annotations

from fleet.executors.base import Events, Executor, Job, JobResult, JobState, JobTimeout, run_job, write_files
from fleet.executors.local import InlineExecutor, PoolExecutor
from fleet.executors.mapping import run_map
from fleet.executors.progress import SweepProgress, summary_table
from sim.errors import ErrorCode, FleetError

EXECUTORS = ("local", "ray")

__all__ = ["EXECUTORS", "Events", "Executor", "InlineExecutor", "Job", "JobResult", "JobState", "JobTimeout",
           "PoolExecutor", "SweepProgress", "make_executor", "run_job", "run_map", "summary_table", "write_files"]


def make_executor(name: str = "local", *, jobs: int | None = None, ray_address: str | None = None,
                  retries: int = 2, preload: tuple[str, ...] = ()) -> Executor:
    """`jobs`: local worker processes (default 1: this process), or the CPUs of a Ray instance started here
    (default: all). `ray_address`: None starts a local Ray instance, "auto" joins the cluster on this machine,
    "host:port" joins that one."""
    if name == "local":
        if ray_address is not None:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "--ray-address needs --executor ray",
                             "add --executor ray, or drop --ray-address")
        n = jobs or 1
        return InlineExecutor() if n <= 1 else PoolExecutor(n, retries=retries, preload=preload)
    if name == "ray":
        from fleet.executors.ray_exec import RayExecutor, import_ray

        import_ray(loopback=ray_address is None)  # fail now, with the install hint, not after planning
        return RayExecutor(ray_address, retries=retries, num_cpus=jobs)
    raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown executor '{name}' (executors: {', '.join(EXECUTORS)})",
                     "use --executor local or --executor ray")
