"""pytest plugin: run mission files as tests (`pytest --missions configs/missions`).

Registered through the `pytest11` entry point (`fleetnav = "fleet.missions.pytest_plugin"`), or load it
by hand with `-p fleet.missions.pytest_plugin`. Each mission file (or every *.yaml in a folder given to
`--missions`) becomes one test per seed; a failed assertion fails the test with the measured numbers,
and each assertion's figure is attached to the JUnit report as a property. Repositories can also use the
`run_mission` fixture in their own tests.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:  # the plugin loads with every pytest run: the simulation is imported only when used
    from fleet.missions.types import RunOutcome


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("fleetnav", "fleetnav missions")
    group.addoption("--missions", action="append", default=[], metavar="PATH",
                    help="run these mission files (or every *.yaml in these folders) as tests")
    group.addoption("--missions-out", default="runs/pytest", metavar="DIR", help="where runs write their outputs")
    group.addoption("--missions-seed", type=int, default=None, help="override the missions' seed")
    group.addoption("--missions-repeat", type=int, default=1, help="run K seeds of each mission")
    group.addoption("--missions-no-record", action="store_true", help="skip the MCAP recordings")
    group.addoption("--missions-executor", default="local", choices=["local", "ray"],
                    help="where mission runs execute: local (default) or ray (pip install 'fleetnav[ray]'); with "
                         "ray or --missions-jobs > 1 every selected mission runs as one sweep when the first runs")
    group.addoption("--missions-jobs", type=int, default=None, metavar="N",
                    help="local: worker processes (default 1, one run at a time in this process); ray: CPUs of "
                         "a Ray instance started here")
    group.addoption("--missions-ray-address", default=None, metavar="ADDR",
                    help="with --missions-executor ray: host:port or auto; default: start a local Ray instance")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "mission: a fleetnav mission run as a test")
    for p in config.getoption("missions"):
        if str(p) not in config.args:  # collect the missions as well as whatever else was asked for
            config.args.append(str(p))


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    chosen = [Path(p).resolve() for p in parent.config.getoption("missions")]
    if file_path.suffix not in (".yaml", ".yml") or not chosen:
        return None
    fp = file_path.resolve()
    if any(fp == c or c in fp.parents for c in chosen):
        return MissionFile.from_parent(parent, path=file_path)
    return None


class MissionFile(pytest.File):
    def collect(self) -> Iterator[pytest.Item]:
        from fleet.missions.loader import load_mission
        from sim.errors import FleetError

        cfg = self.config
        try:
            base = load_mission(self.path).seed
        except FleetError:
            base = 0  # the item fails with the loader's message
        first = cfg.getoption("missions_seed")
        first = base if first is None else first
        for k in range(max(1, cfg.getoption("missions_repeat"))):
            item = MissionItem.from_parent(self, name=f"seed={first + k}", seed=first + k)
            item.add_marker(pytest.mark.mission)
            yield item


class MissionFailed(Exception):
    pass


class MissionSetupError(Exception):
    """The mission file cannot be run (bad file, missing world or robot model): a test error, not a failure."""


class MissionItem(pytest.Item):
    def __init__(self, *, seed: int, **kw: Any) -> None:
        super().__init__(**kw)
        self.seed = seed

    def setup(self) -> None:
        # Loading in the setup phase makes a bad mission an <error> in JUnit, distinct from a failed assertion.
        from fleet.missions.loader import load_mission
        from sim.errors import FleetError

        try:
            load_mission(self.path)
        except FleetError as exc:
            raise MissionSetupError(exc.message + (f" ({exc.hint})" if exc.hint else "")) from None

    def request(self) -> Any:
        from fleet.missions.batch import RunRequest

        cfg = self.config
        out = Path(cfg.getoption("missions_out")) / self.path.stem / f"seed-{self.seed}"
        return RunRequest(str(self.path), self.seed, str(out), record=not cfg.getoption("missions_no_record"))

    def runtest(self) -> None:
        from fleet.missions.batch import run_file

        cfg = self.config
        if cfg.getoption("missions_executor") == "ray" or (cfg.getoption("missions_jobs") or 1) > 1:
            outcome = _sweep(self)
        else:
            outcome = run_file(self.request())
        for a in outcome.report.get("assertions", []):
            self.user_properties.append((a["name"], f"{'pass' if a['passed'] else 'FAIL'}: {a['measured']}"))
        if not outcome.passed:
            lines = [f"{a['name']}: {a['message']}" for a in outcome.report.get("assertions", []) if not a["passed"]]
            raise MissionFailed("\n".join(lines) + f"\n(outputs: {outcome.out_dir})")

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> str:
        if isinstance(excinfo.value, MissionFailed):
            return f"mission {self.path.name} [{self.name}] failed:\n{excinfo.value}"
        if isinstance(excinfo.value, MissionSetupError):
            return f"mission {self.path.name} cannot be set up: {excinfo.value}"
        return str(super().repr_failure(excinfo))

    def reportinfo(self) -> tuple[Path, int | None, str]:
        return self.path, None, f"mission {self.path.name} [{self.name}]"


_RESULTS = pytest.StashKey[dict[str, "RunOutcome"]]()


def _sweep(item: MissionItem) -> RunOutcome:
    """The first mission item runs every selected mission item through the executor; each then reads its own."""
    from fleet.missions.batch import run_batch

    cfg = item.config
    if _RESULTS not in cfg.stash:
        items = [i for i in item.session.items if isinstance(i, MissionItem)]
        outcomes = run_batch([i.request() for i in items], jobs=cfg.getoption("missions_jobs"), show_progress=False,
                             executor=cfg.getoption("missions_executor"),
                             ray_address=cfg.getoption("missions_ray_address"))
        by_dir = {str(o.out_dir): o for o in outcomes}
        cfg.stash[_RESULTS] = {i.nodeid: by_dir[i.request().out_dir] for i in items if i.request().out_dir in by_dir}
    results = cfg.stash[_RESULTS]
    if item.nodeid not in results:
        raise MissionFailed("the sweep was canceled before this run finished")
    return results[item.nodeid]


@pytest.fixture
def run_mission(tmp_path: Path) -> Callable[..., RunOutcome]:
    """`run_mission("configs/missions/x.yaml", seed=3, time_limit=20)` → RunOutcome (report, out_dir, passed)."""
    from fleet.missions.batch import RunRequest, run_file

    def run(path: str | Path, *, seed: int | None = None, time_limit: float | None = None,
            record: bool = False) -> RunOutcome:
        out = tmp_path / f"{Path(path).stem}-{seed}"
        return run_file(RunRequest(str(path), seed, str(out), record, time_limit))

    return run
