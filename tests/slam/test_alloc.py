"""slam/alloc.py: with the thresholds set, arrays of tens of MB come from the heap and stay in it once freed
(reused by the next scan without faulting pages in). With glibc's defaults the first round is mmapped and
unmapped, and the heap's top is trimmed back to the OS after the second (measured: 25 of 75 MB kept)."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from slam.alloc import retain_freed_memory


class _MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                               "fsmblks", "uordblks", "fordblks", "keepcost")]


def test_freed_arrays_stay_in_the_heap() -> None:
    if not retain_freed_memory():
        pytest.skip("not glibc, or thresholds set by the environment")
    try:
        info = ctypes.CDLL(None).mallinfo2
    except AttributeError:
        pytest.skip("glibc older than 2.33")
    info.restype = _MallInfo2
    size = 25 << 20  # under the 32 MB mmap threshold; three of them over glibc's largest default trim threshold
    for _ in range(2):
        mapped = info().hblkhd  # other tests' live arrays may be mmapped already
        arrays = [np.ones(size // 8) for _ in range(3)]
        assert info().hblkhd - mapped < size  # these are not
        del arrays
        assert info().fordblks >= 3 * size  # freed, and kept
    assert retain_freed_memory()  # idempotent
