"""One YAML loader for every config: pydantic v2 models, errors that name file, line and field."""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from sim.errors import ErrorCode, FleetError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base for every config model: a typo in a key is an error, never silently ignored."""

    model_config = ConfigDict(extra="forbid", frozen=False, validate_assignment=True)


def _node_at(root: yaml.Node | None, loc: tuple[int | str, ...]) -> yaml.Node | None:
    """Walk a composed YAML node tree along a pydantic error location; stop at the deepest match."""
    node = root
    for key in loc:
        if isinstance(node, yaml.MappingNode):
            nxt = next((v for k, v in node.value if getattr(k, "value", None) == str(key)), None)
            if nxt is None:
                # The offending key itself (extra field): point at the key node.
                nxt = next((k for k, _ in node.value if getattr(k, "value", None) == str(key)), None)
                return nxt or node
            node = nxt
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and key < len(node.value):
            node = node.value[key]
        else:
            return node
    return node


def format_validation_error(err: ValidationError, source: str, root: yaml.Node | None) -> str:
    lines = []
    for e in err.errors():
        loc = tuple(x for x in e["loc"] if not (isinstance(x, str) and x.startswith("function-")))
        field = ".".join(str(x) for x in loc) or "(top level)"
        node = _node_at(root, loc)
        where = f"{source}:{node.start_mark.line + 1}" if node is not None else source
        lines.append(f"{where}: field '{field}': {e['msg']}")
    return "; ".join(lines)


def parse_yaml_text(text: str, source: str) -> tuple[Any, yaml.Node | None]:
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark else source
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{where}: malformed YAML: {getattr(exc, 'problem', exc)}",
                         "fix the YAML syntax at that line") from exc
    return data, root


def load_model_from_text(text: str, model: type[M], source: str = "<string>") -> M:
    data, root = parse_yaml_text(text, source)
    if data is None:
        data = {}
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, format_validation_error(exc, source, root),
                         f"see the {model.__name__} schema") from exc


def load_yaml(path: str | Path, model: type[M]) -> M:
    """Load `path` into `model`; any problem is a FleetError naming the file, line and field."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc
    return load_model_from_text(text, model, str(p))


def dump_yaml(model: BaseModel, path: str | Path) -> None:
    """Write the config actually used next to a run's outputs."""
    Path(path).write_text(yaml.safe_dump(model.model_dump(mode="json"), sort_keys=False), encoding="utf-8")
