"""Work arrays of the Embree ray caster, kept from cast to cast.

A 100-robot lidar sweep is 36,000 rays: every cast used to allocate ~8 MB of fresh temporaries, and the allocator
handed most of it back to the system in between, so each cast paid ~500 page faults (~1 ms) before any
arithmetic. The caster's full-length arrays (float32 rays for Embree, hit distances, masks) now live here, by
name, and are reused while the batch fits; a bigger batch (more robots) reallocates, a smaller one uses the front.

Nothing handed out of a cast may be one of these arrays: the next cast overwrites them.
"""

from __future__ import annotations

import numpy as np


class Scratch:
    """Named work arrays of at least n rows: get() returns the first n rows of a kept array (contiguous)."""

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}
        self.allocations = 0  # arrays (re)allocated so far, for tests

    def get(self, name: str, n: int, dtype: type | np.dtype, width: int = 0) -> np.ndarray:
        """Rows [0, n) of the array `name`: shape (n,) or, with width, (n, width). Reallocated (uninitialised)
        when it holds fewer than n rows or another dtype or width."""
        a = self._arrays.get(name)
        shape = (n, width) if width else (n,)
        if a is None or a.shape[0] < n or a.shape[1:] != shape[1:] or a.dtype != np.dtype(dtype):
            a = self._arrays[name] = np.empty(shape, dtype)
            self.allocations += 1
        return a[:n]


__all__ = ["Scratch"]
