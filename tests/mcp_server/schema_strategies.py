"""Hypothesis strategies from a tool's JSON input schema (hypothesis-jsonschema is not installed).

Covers what pydantic emits for our signatures: objects with $defs/$ref, anyOf, enum/const, strings (length
bounds; `pattern` is not generated, the server must reject what does not match), integers and numbers with
(exclusive) bounds, booleans, null, arrays with items/prefixItems (tuples) and free dicts. Known argument names
draw from values that exist in the test world half of the time, so calls reach past the "unknown" checks;
sizes that only cost time (steps, timeouts, counts) are capped, which keeps them inside the schema.
"""

from __future__ import annotations

import math
from typing import Any

from hypothesis import strategies as st

# Values that exist in the fuzzed world (robots r1, r2; task t1 after a navigate) or probe the workspace fence.
KNOWN: dict[str, list[Any]] = {
    "robot": ["r1", "r2", "ghost"], "name": ["r1", "crate", "ghost"], "task_id": ["t1", "t2", "nope"],
    "behaviour_id": ["b1", "nope"], "marker_id": ["m1", "m9"], "job_id": ["mission1", "challenge1", "nope"],
    "map_name": ["arena", "nope"], "world": ["empty", "nope", "../x.world"], "challenge": ["nope", "../c.yaml"],
    "path": ["maps/a.yaml", "rec/a.mcap", "../../etc/passwd", "/etc/hosts", "out.world", "hop.yaml"],
    "directory": [".", "nope", ".."], "file": ["nope.urdf", "/etc/passwd"],
    "parent": ["map", "r1/base_link", "nowhere"], "child": ["r1/lidar", "r2", "nowhere"],
    "ns": ["default", "network"], "planner": ["theta_star", "astar", "nope"],
    "controller": ["pure_pursuit", "nope"], "type": ["go_to", "wait", "nope"],
}
# Upper bounds for arguments whose size only costs test time (all within every tool's schema).
CAPS: dict[str, float] = {
    "steps": 100, "count": 4, "timeout_s": 1.0, "duration": 0.5, "max_wall_s": 1.0, "wait_s": 0.2,
    "window_s": 0.3, "runs": 1, "limit": 20, "max_px": 200, "rounds": 2, "ttl_s": 5.0, "lifetime_s": 5.0,
    "time_limit": 2.0, "dwell_s": 0.5, "seed": 10, "speed": 50.0, "offset": 10, "since_seq": 50,
}
MAX_ITEMS = 4


def from_schema(schema: dict[str, Any]) -> st.SearchStrategy[dict[str, Any]]:
    return _object(schema, schema.get("$defs", {}))


def _object(s: dict[str, Any], defs: dict[str, Any]) -> st.SearchStrategy[dict[str, Any]]:
    props = s.get("properties")
    if props is None:  # a free dict (dict[str, Any] / dict[str, float])
        vals = _value(s["additionalProperties"], defs, "") if isinstance(s.get("additionalProperties"), dict) \
            else st.one_of(st.floats(-10, 10, allow_nan=False, allow_infinity=False), st.integers(-5, 5),
                           st.text(max_size=6))
        return st.dictionaries(st.sampled_from(["goal", "x", "time_horizon", "policy", "odometry", "wait_s",
                                                "gyro_std", "radius"]), vals, max_size=3)
    required = set(s.get("required", []))
    fields = {k: _value(v, defs, k) for k, v in props.items()}
    return st.fixed_dictionaries({k: f for k, f in fields.items() if k in required},
                                 optional={k: f for k, f in fields.items() if k not in required})


def _value(s: dict[str, Any], defs: dict[str, Any], name: str) -> st.SearchStrategy[Any]:
    if "$ref" in s:
        return _value(defs[s["$ref"].split("/")[-1]], defs, name)
    if "anyOf" in s:
        return st.one_of([_value(o, defs, name) for o in s["anyOf"]])
    if "enum" in s:
        return st.sampled_from(s["enum"])
    if "const" in s:
        return st.just(s["const"])
    t = s.get("type")
    if t == "object":
        return _object(s, defs)
    if t == "string":
        text = st.text(min_size=s.get("minLength", 0), max_size=min(s.get("maxLength", 12), 12))
        return st.one_of(st.sampled_from(KNOWN[name]), text) if name in KNOWN else text
    if t == "boolean":
        return st.booleans()
    if t == "null":
        return st.none()
    if t in ("integer", "number"):
        return _number(s, name, t == "integer")
    if t == "array":
        if "prefixItems" in s:
            return st.tuples(*[_value(x, defs, name) for x in s["prefixItems"]]).map(list)
        lo = s.get("minItems", 0)
        items = _value(s.get("items", {"type": "number"}), defs, name)
        return st.lists(items, min_size=lo, max_size=max(lo, min(s.get("maxItems", MAX_ITEMS), MAX_ITEMS)))
    raise NotImplementedError(f"schema {s}")


def _number(s: dict[str, Any], name: str, integer: bool) -> st.SearchStrategy[Any]:
    lo = s.get("minimum", s.get("exclusiveMinimum", -1e3 if integer else -50.0))
    hi = s.get("maximum", s.get("exclusiveMaximum", 1e3 if integer else 50.0))
    hi = min(hi, CAPS.get(name, math.inf))
    if integer:
        return st.integers(math.ceil(lo) + ("exclusiveMinimum" in s), math.floor(hi))
    return st.floats(lo, hi, exclude_min="exclusiveMinimum" in s, exclude_max="exclusiveMaximum" in s,
                     allow_nan=False, allow_infinity=False)
