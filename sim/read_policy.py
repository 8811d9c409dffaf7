"""Which files SDF/URDF loading may read: a hook the service sets while it loads what a front door sent.

`resolve_uri` (includes, meshes, textures) and URDF mesh paths call `allowed(path)`. Outside a `policy(...)`
block everything is allowed (a local user loading their own files); inside it, a path the policy refuses is
treated exactly like a missing file, so a refusal is no existence oracle.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

_POLICY: ContextVar[Callable[[Path], bool] | None] = ContextVar("fleetnav_read_policy", default=None)


def allowed(path: Path) -> bool:
    check = _POLICY.get()
    return check is None or check(path)


def policy_active() -> bool:
    return _POLICY.get() is not None


@contextmanager
def policy(check: Callable[[Path], bool]) -> Iterator[None]:
    token = _POLICY.set(check)
    try:
        yield
    finally:
        _POLICY.reset(token)
