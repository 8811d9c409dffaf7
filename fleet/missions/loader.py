"""Load and check mission files: every problem is a FleetError naming file, line and field.

Structure and values are pydantic's (through sim.config's YAML locator); the references between sections
(robot names, task keys, spawn points, task and behaviour types) are checked here against the mission and
its world, and reported the same way, at the line of the offending field.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from pydantic_core import InitErrorDetails, PydanticCustomError

from fleet.missions.assertions import ASSERTIONS
from fleet.missions.events import EVENTS
from fleet.missions.schema import Mission
from fleet.paths import world_file
from sim.config import format_validation_error, parse_yaml_text
from sim.errors import ErrorCode, FleetError

Problem = tuple[tuple[int | str, ...], str, Any]
HINT = "see docs/missions.md and configs/missions/mission.schema.json"
_TAGS = set(ASSERTIONS.names()) | set(EVENTS.names())


def load_mission(path: str | Path) -> Mission:
    """Parse, validate and cross-check `path`; the world is resolved relative to the file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc
    return mission_from_text(text, str(p), base=p.parent)


def mission_from_text(text: str, source: str = "<string>", base: Path | None = None) -> Mission:
    data, root = parse_yaml_text(text, source)
    try:
        mission = Mission.model_validate(data if data is not None else {})
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, format_validation_error(_untagged(exc), source, root),
                         HINT) from exc
    world = resolve_world(mission.world, base)
    problems: list[Problem] = [] if world is not None else [(("world",), f"no world '{mission.world}' (a name in "
                                              "configs/worlds or an SDF path relative to the mission)",
                                              mission.world)]
    problems += check_references(mission, world)
    mission, model_problems = resolve_models(mission, base)
    problems += model_problems
    if problems:
        raise FleetError(ErrorCode.INVALID_CONFIG, format_validation_error(_as_error(problems), source, root), HINT)
    assert world is not None
    return mission.model_copy(update={"world": str(world)})


def resolve_models(m: Mission, base: Path | None) -> tuple[Mission, list[Problem]]:
    """Robot models as absolute paths (relative ones start from the mission's folder), each loaded once so a
    missing file or a bad description is a load error at its line, not a failure mid-run."""
    from fleet.paths import ROBOT_SUFFIXES, robot_file, robot_model

    problems: list[Problem] = []
    checked: dict[str, str | None] = {}

    def resolve(loc: tuple[int | str, ...], model: str) -> str:
        if model not in checked:
            try:
                is_file = not model.lstrip().startswith("<") and Path(model).suffix in ROBOT_SUFFIXES
                robot_model(str(robot_file(model, base)) if is_file else model)
                checked[model] = str(robot_file(model, base)) if is_file else model  # names stay names
            except FleetError as exc:
                checked[model] = None
                problems.append((loc, exc.message, model))
        return checked[model] or model

    robots = [r.model_copy(update={"model": resolve(("robots", i, "model"), r.model)})
              for i, r in enumerate(m.robots)]
    fleets = [f.model_copy(update={"model": resolve(("fleets", i, "model"), f.model)}) if f.model else f
              for i, f in enumerate(m.fleets)]
    return m.model_copy(update={"robots": robots, "fleets": fleets}), problems


def resolve_world(name: str, base: Path | None) -> Path | None:
    if base is not None and (base / name).is_file():
        return (base / name).resolve()
    try:
        return world_file(name).resolve()
    except FleetError:
        return None


def validate_files(paths: Iterable[str | Path]) -> list[tuple[str, str | None]]:
    """(path, None) for each valid file, (path, error text) for each invalid one."""
    out: list[tuple[str, str | None]] = []
    for p in paths:
        try:
            load_mission(p)
            out.append((str(p), None))
        except FleetError as exc:
            out.append((str(p), exc.message))
    return out


# ---- cross-references --------------------------------------------------------------------------------


def check_references(m: Mission, world: Path | None) -> list[Problem]:
    from fleet.swarm import behaviour_names
    from fleet.tasks import allocatable_types, task_types

    names = m.robot_names()
    out: list[Problem] = []

    def robot(loc: tuple[int | str, ...], name: str | None) -> None:
        if name is not None and name not in names:
            out.append((loc, f"unknown robot '{name}' (robots: {', '.join(names)})", name))

    def one_of(loc: tuple[int | str, ...], value: str, valid: list[str], kind: str) -> None:
        if value not in valid:
            out.append((loc, f"unknown {kind} '{value}' (valid: {', '.join(valid) or 'none'})", value))

    seen: set[str] = set()
    for i, r in enumerate(m.robots):
        if r.name in seen:
            out.append((("robots", i, "name"), f"robot '{r.name}' is listed twice", r.name))
        seen.add(r.name)
    if world is not None and any(r.spawn for r in m.robots):
        out += _spawn_points(m, world)
    keys = m.task_keys()
    for i, k in enumerate(keys):
        if k in keys[:i]:
            loc: tuple[int | str, ...] = ("tasks", i, "id") if i < len(m.tasks) else \
                ("allocation", "tasks", i - len(m.tasks), "id")
            out.append((loc, f"task key '{k}' is used twice", k))
    for i, t in enumerate(m.tasks):
        robot(("tasks", i, "robot"), t.robot)
        one_of(("tasks", i, "type"), t.type, task_types(), "task type")
    if m.allocation is not None:
        for j, name in enumerate(m.allocation.robots or []):
            robot(("allocation", "robots", j), name)
        for i, a in enumerate(m.allocation.tasks):
            one_of(("allocation", "tasks", i, "type"), a.type, allocatable_types(), "allocatable task type")
    for i, b in enumerate(m.behaviours):
        one_of(("behaviours", i, "type"), b.type, behaviour_names(), "behaviour")
        for j, name in enumerate(b.robots or []):
            robot(("behaviours", i, "robots", j), name)
    for i, e in enumerate(m.events):
        robot(("events", i, "robot"), getattr(e, "robot", None))
        for j, name in enumerate(getattr(e, "robots", None) or []):
            robot(("events", i, "robots", j), name)
        if e.at > m.time_limit:
            out.append((("events", i, "at"), f"at {e.at} s is after the time limit {m.time_limit} s", e.at))
    for i, proc in enumerate(m.agents.processes if m.agents else []):
        for j, name in enumerate(proc.robots):
            robot(("agents", "processes", i, "robots", j), name)
    for i, s in enumerate(m.slam):
        robot(("slam", i, "robot"), s.robot)
    robot(("recording", "camera_robot"), m.recording.camera_robot)
    out += _assertion_refs(m, names, keys)
    return out


def _assertion_refs(m: Mission, names: list[str], keys: list[str]) -> list[Problem]:
    out: list[Problem] = []
    types = {k: t.type for k, t in zip(keys, m.tasks, strict=False)} | \
        ({a.id: a.type for a in m.allocation.tasks} if m.allocation else {})
    for i, a in enumerate(m.assertions):
        r = getattr(a, "robot", None)
        if r is not None and r not in names:
            out.append((("assertions", i, "robot"), f"unknown robot '{r}' (robots: {', '.join(names)})", r))
        for j, name in enumerate(getattr(a, "robots", None) or []):
            if name not in names:
                out.append((("assertions", i, "robots", j), f"unknown robot '{name}'", name))
        for k in (getattr(a, "task", None), *(getattr(a, "tasks", None) or [])):
            if k is not None and k not in keys:
                out.append((("assertions", i, "task"), f"unknown task key '{k}' (tasks: {', '.join(keys) or 'none'})",
                            k))
        task = getattr(a, "task", None)
        if task in types and a.type == "coverage" and types[task] != "cover_area":
            out.append((("assertions", i, "task"), f"task '{task}' is a {types[task]}, not a cover_area", task))
        if task in types and a.type in ("reach_goal", "barn_score") and types[task] != "go_to":
            out.append((("assertions", i, "task"), f"task '{task}' is a {types[task]}, not a go_to", task))
        b = getattr(a, "behaviour", None)
        if b is not None and b not in m.behaviour_keys():
            out.append((("assertions", i, "behaviour"), f"unknown behaviour key '{b}' (behaviours: "
                        f"{', '.join(m.behaviour_keys()) or 'none'})", b))
    return out


def _spawn_points(m: Mission, world: Path) -> list[Problem]:
    from sim import parse_sdf

    known = [sp.name for sp in parse_sdf(world).spawn_points]
    return [(("robots", i, "spawn"), f"no spawn point '{r.spawn}' in {world.name} (spawn points: "
             f"{', '.join(known) or 'none'})", r.spawn) for i, r in enumerate(m.robots)
            if r.spawn is not None and r.spawn not in known]


# ---- errors at the right line ------------------------------------------------------------------------


def _as_error(problems: list[Problem]) -> ValidationError:
    return ValidationError.from_exception_data("Mission", [
        InitErrorDetails(type=PydanticCustomError("reference", msg), loc=loc, input=value)
        for loc, msg, value in problems])


def _untagged(exc: ValidationError) -> ValidationError:
    """Drop the union tag pydantic puts in a location (`assertions.0.reach_goal.within`), so the location
    is the YAML path and the line found is the field's own."""
    details = []
    for e in exc.errors():
        loc = tuple(x for k, x in enumerate(e["loc"])
                    if not (k > 0 and isinstance(e["loc"][k - 1], int) and x in _TAGS))
        details.append(InitErrorDetails(type=PydanticCustomError(e["type"], e["msg"]), loc=loc, input=e["input"]))
    return ValidationError.from_exception_data(exc.title, details)
