"""The C routes' array addresses equal NumPy's ``ndarray.ctypes.data`` on every kind of array."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime.addresses import address

BASE = np.arange(60.0).reshape(10, 6)
READ_ONLY = BASE.copy()
READ_ONLY.flags.writeable = False


@pytest.mark.parametrize(
    "arr",
    [
        BASE,  # writeable, contiguous: the fast path
        BASE[3:],  # a contiguous view that starts inside its base
        BASE[:, 2],  # a strided column: the fallback
        READ_ONLY,  # read-only: the fallback
        np.empty((0, 6)),  # empty: the fallback
        np.array(2.5),  # 0-d
        np.zeros(7, dtype=np.int8),
    ],
    ids=["contiguous", "view", "strided", "read-only", "empty", "0-d", "int8"],
)
def test_address_is_the_arrays_first_byte(arr):
    assert address(arr) == arr.ctypes.data
