"""The Python side of the C allowed-twist driver (:mod:`eigentwist.runtime.c_allowed`) on a
stand-in of ``et_allowed_twists`` that reads its inputs by address, as C does, and writes the
NumPy rule's bases (no compiler needed)."""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from eigentwist.runtime import allowed, c_allowed
from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD


def doubles(address, count):
    return np.ctypeslib.as_array((ctypes.c_double * count).from_address(address))


class StandIn:
    """``rc et_allowed_twists(n, rows, stride, c, pick, m, cand, per_pose, rtol, tol_col, out)``:
    each pose's picked rows read from ``rows + 8 * (stride * i + 6 * pick[k])``, its
    candidates from ``cand`` (per pose or shared), the NumPy rule's basis written to ``out``."""

    def __init__(self, rc=0):
        self.calls, self.rc = [], rc

    def __call__(self, n, rows, stride, c, pick, m, cand, per_pose, rtol, tol_col, out):
        self.calls.append(dict(n=n, stride=stride, c=c, pick=list(pick)[:c], m=m, per_pose=per_pose))
        self.calls[-1].update(rtol=rtol, tol_col=tol_col, out=out, rows=rows, cand=cand)
        for i in range(n):
            A = np.array([doubles(rows + 8 * (stride * i + 6 * pick[k]), 6) for k in range(c)]).reshape(1, c, 6)
            E = doubles(cand + (8 * 6 * m * i if per_pose else 0), 6 * m).reshape(6, m)
            got = allowed.allowed_twists(A, E, rtol) if tol_col == allowed.VANISHING else np.full((1, 6, m), 7.0)
            doubles(out + 8 * 6 * m * i, 6 * m)[:] = got.reshape(-1)
        return self.rc


@pytest.fixture
def stand_in(monkeypatch):
    fn = StandIn()
    monkeypatch.setattr(c_allowed, "driver", lambda: fn)
    return fn


def _rows(n, rng):
    J = rng.standard_normal((n, 3, 2, 6))  # (poses, legs, rows per leg, twist)
    return J, [1, 3, 4]


def test_picked_rows_and_shared_candidates_reach_the_driver(stand_in):
    rng = np.random.default_rng(1)
    J, picks = _rows(5, rng)
    E = allowed.coordinate_twists(["x", "y", "rot_z"])
    got = allowed.allowed_twists(J, E, compiled=True, picks=picks)
    want = allowed.allowed_twists(J.reshape(5, 6, 6)[:, picks], E)
    assert np.array_equal(got, want)
    (call,) = stand_in.calls
    assert (call["n"], call["stride"], call["c"], call["pick"], call["m"]) == (5, 36, 3, picks, 3)
    assert call["per_pose"] == 0 and call["rtol"] == allowed.DEPENDENT_RTOL and call["tol_col"] == allowed.VANISHING
    assert type(call["rtol"]) is float and type(call["tol_col"]) is float


def test_rows_without_picks_and_candidates_per_pose(stand_in):
    rng = np.random.default_rng(2)
    A = rng.standard_normal((4, 3, 6))
    E = rng.standard_normal((4, 6, 2))
    got = c_allowed.allowed_twists(A, E, 1e-9, allowed.VANISHING)
    assert np.array_equal(got, allowed.allowed_twists(A, E))
    (call,) = stand_in.calls
    assert call["pick"] == [0, 1, 2] and call["stride"] == 18 and call["per_pose"] == 1 and call["m"] == 2
    # integer and Fortran-ordered inputs: C reads C-ordered doubles
    Ai = np.asfortranarray(np.arange(4 * 3 * 6).reshape(4, 3, 6))
    assert np.array_equal(
        c_allowed.allowed_twists(Ai, E, 1e-9, allowed.VANISHING), allowed.allowed_twists(Ai.astype(float), E)
    )


def test_ranges_of_blocks_on_threads(stand_in):
    rng = np.random.default_rng(3)
    n = 2 * MIN_BLOCKS_PER_THREAD * c_allowed.BLOCK + 9
    A = rng.standard_normal((n, 2, 6))
    E = rng.standard_normal((n, 6, 3))
    out = c_allowed.allowed_twists(A, E, 1e-9, allowed.VANISHING, threads=2)
    assert np.array_equal(out, allowed.allowed_twists(A, E))  # each range reads its own rows and candidates
    assert len(stand_in.calls) > 1 and sum(c["n"] for c in stand_in.calls) == n
    starts = sorted((c["out"] - stand_in.calls[0]["out"]) // (8 * 18) for c in stand_in.calls)
    assert starts[0] == 0 and all(s % c_allowed.BLOCK == 0 for s in starts)
    assert sorted((c["rows"] - A.ctypes.data) // (8 * 12) for c in stand_in.calls) == starts
    shared = allowed.coordinate_twists(["x", "y", "z"])  # one (6, m) for every range
    assert np.array_equal(
        c_allowed.allowed_twists(A, shared, 1e-9, allowed.VANISHING, threads=2), allowed.allowed_twists(A, shared)
    )
    stand_in.calls.clear()
    c_allowed.allowed_twists(A, E, 1e-9, 1.0)  # one thread unless asked
    assert len(stand_in.calls) == 1


def test_integer_candidates_are_read_as_doubles(stand_in):
    A = np.random.default_rng(6).standard_normal((3, 2, 6))
    E = np.eye(6, dtype=int)[:, [0, 3, 5]]
    assert np.array_equal(c_allowed.allowed_twists(A, E, 1e-9, allowed.VANISHING), allowed.allowed_twists(A, E))


def test_a_refusal_and_no_driver(monkeypatch):
    monkeypatch.setattr(c_allowed, "driver", lambda: StandIn(rc=1))
    with pytest.raises(RuntimeError) as err:
        c_allowed.allowed_twists(np.zeros((2, 1, 6)), np.eye(6)[:, :3], 1e-9, 1e-8)
    assert str(err.value) == "the C allowed-twist driver ran out of memory"
    monkeypatch.setattr(c_allowed, "driver", lambda: None)
    with pytest.raises(RuntimeError) as err:
        c_allowed.allowed_twists(np.zeros((2, 1, 6)), np.eye(6)[:, :3], 1e-9, 1e-8)
    assert str(err.value) == "the C allowed-twist driver could not be built (no compiler)"
    # the rule falls back to NumPy where the driver cannot be built
    A = np.random.default_rng(4).standard_normal((3, 2, 6))
    E = np.eye(6)[:, :3]
    assert np.array_equal(allowed.allowed_twists(A, E, compiled=True), allowed.allowed_twists(A, E))


def test_the_driver_is_built_once_and_none_without_a_compiler(monkeypatch):
    from eigentwist.runtime import ccompile

    monkeypatch.setattr(c_allowed, "_DRIVER", [])
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: None)
    assert c_allowed.driver() is None and c_allowed._DRIVER == [None]

    class Lib:
        et_allowed_twists = ctypes.CFUNCTYPE(ctypes.c_int)(lambda: 0)
        et_reduce = ctypes.CFUNCTYPE(None)(lambda: None)

    seen = []
    monkeypatch.setattr(c_allowed, "_DRIVER", [])
    monkeypatch.setattr(c_allowed, "_LIBRARIES", [])
    monkeypatch.setattr(c_allowed, "_REDUCE", [])
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: seen.append((source, name)) or Lib())
    fn = c_allowed.driver()
    assert fn is Lib.et_allowed_twists and c_allowed.driver() is fn and seen == [(c_allowed.SOURCE, "allowed")]
    assert fn.restype is ctypes.c_int and len(fn.argtypes) == 11
    assert c_allowed._REDUCE == [Lib.et_reduce] and Lib.et_reduce.restype is None
    assert Lib.et_reduce.argtypes == [ctypes.c_int64, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]


def test_the_reduction_falls_back_to_numpy_without_the_driver(monkeypatch):
    monkeypatch.setattr(c_allowed, "_DRIVER", [None])
    rng = np.random.default_rng(2)
    X, B = rng.standard_normal((5, 6, 6)), rng.standard_normal((5, 6, 2))
    assert np.array_equal(allowed.reduce(X, B, compiled=True), np.swapaxes(B, 1, 2) @ X @ B)
    with pytest.raises(RuntimeError, match="no compiler"):
        c_allowed.reduce(X, B)
