"""Every job starts as if in a fresh process: the process-wide id counters (task `t<n>`, deadlock `d<n>`,
barrier `sync<n>`, calibration `cal<n>`, behaviour
`b<n>`, allocation request `q<n>`) start again at 1.

Those ids reach a run's recording (the /events channel names the task), so without this the n-th run a worker
process executes would record `t7` where a fresh process records `t1`, and local, pooled and Ray runs of one
seed would differ in their MCAP bytes. (The lasting fix is ids counted per FleetService; until then this list
names every process-wide counter in the fleet package.)
"""

from __future__ import annotations

import importlib
import itertools

COUNTERS = (("fleet.tasks.base", "_ids"), ("fleet.deadlock", "_ids"), ("fleet.sync", "_ids"),
            ("fleet.ops_calibration", "_ids"), ("fleet.swarm.manager", "_ids"), ("fleet.allocation.requests", "_ids"))


def reset_id_counters() -> None:
    for module, attr in COUNTERS:
        try:
            mod = importlib.import_module(module)
        except ImportError:
            continue
        if isinstance(getattr(mod, attr, None), itertools.count):
            setattr(mod, attr, itertools.count(1))
