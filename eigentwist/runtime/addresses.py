"""Addresses of NumPy arrays for the C calls (ctypes), taken cheaply.

``ndarray.ctypes.data`` builds NumPy's ctypes interface object on every access (about
1.5 µs); a C pass over one block of 64 poses takes ~30 µs and reads several arrays, so the
C routes take addresses through :func:`address`, which reads them off a ctypes view of the
array's buffer (about 0.4 µs) wherever the buffer allows one.
"""

from __future__ import annotations

import ctypes

import numpy as np

__all__ = ["address"]

_view = ctypes.c_char.from_buffer
_addressof = ctypes.addressof


def address(arr: np.ndarray) -> int:
    """The address (bytes) of ``arr``'s first element: ``arr.ctypes.data``. Read off a
    ctypes view of a writeable, contiguous, non-empty buffer; any other array (read-only,
    strided, empty) falls back to ``arr.ctypes.data``."""
    try:
        return _addressof(_view(arr))
    except (TypeError, ValueError, BufferError):
        return arr.ctypes.data
