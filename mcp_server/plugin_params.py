"""Typed settings for plugin-chosen tools (swarm behaviours, avoidance): the JSON schema an assistant sees lists
every plugin's fields (one alternative per registered type, from its pydantic config), and the call is
validated against the model of the type it names, so a wrong field is an INVALID_ARGUMENT naming it."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel, ValidationError

from sim.errors import ErrorCode, FleetError, unknown_name


def _inline(node: Any, defs: Mapping[str, Any]) -> Any:
    """Replace local `$ref`s by their definitions: a parameter's schema is embedded in the tool's, where the
    model's own `$defs` would not resolve."""
    if isinstance(node, dict):
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/$defs/"):
            return _inline(defs[ref.split("/")[-1]], defs)
        return {k: _inline(v, defs) for k, v in node.items() if k != "$defs"}
    if isinstance(node, list):
        return [_inline(v, defs) for v in node]
    return node


def settings_schema(configs: Mapping[str, type[BaseModel]], kind: str) -> dict[str, Any]:
    """One object schema per type (its fields without `type`, unknown keys forbidden), as `anyOf` + null."""
    alts: list[dict[str, Any]] = []
    for name, model in configs.items():
        s = model.model_json_schema()
        s = _inline(s, s.get("$defs", {}))
        props = {k: v for k, v in s.get("properties", {}).items() if k != "type"}
        alt: dict[str, Any] = {"type": "object", "description": f"{kind} '{name}'", "properties": props,
                               "additionalProperties": False}
        required = [r for r in s.get("required", []) if r != "type"]
        if required:
            alt["required"] = required
        alts.append(alt)
    return {"anyOf": [*alts, {"type": "null"}], "default": None}


def checked(configs: Mapping[str, type[BaseModel]], kind: str, name: str,
            settings: Mapping[str, Any] | None) -> dict[str, Any]:
    """Validate `settings` against the config of type `name`; the settings given (JSON-safe), or a FleetError
    INVALID_ARGUMENT naming each wrong field and listing the valid ones."""
    if name not in configs:
        raise unknown_name(kind, name, list(configs), ErrorCode.INVALID_ARGUMENT)
    if settings is None:
        return {}
    if not isinstance(settings, Mapping):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{kind} '{name}' settings must be an object, got "
                         f"{type(settings).__name__}")
    model = configs[name]
    if "type" in settings:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{kind} settings: field 'type' is not a setting",
                         f"the {kind} is chosen by its own argument")
    try:
        model.model_validate({"type": name, **settings})
    except ValidationError as exc:
        fields = "; ".join(f"{'.'.join(str(p) for p in e['loc']) or '(settings)'}: {e['msg']}"
                           for e in exc.errors(include_url=False))
        valid = [f for f in model.model_fields if f != "type"]
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{kind} '{name}' settings: {fields}",
                         f"fields of '{name}': {', '.join(valid) or 'none'}") from None
    return dict(settings)
