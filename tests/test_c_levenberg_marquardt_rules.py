"""The Python side of the compiled Levenberg-Marquardt driver (:mod:`eigentwist.runtime.c_levenberg_marquardt`)
on a stand-in of its C function written here: the stand-in reads each pose's inputs through the
table of addresses and strides it is given (input k of pose i at ``address_k + 8 stride_k i``, as
the C code does), moves each joint coordinate by a known function of them and writes a known
norm, so each pose's results say which values reached it. The library's declared argument types
are checked against the C declaration in ``SOURCE``. No compile.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from eigentwist.runtime import c_levenberg_marquardt as clm
from eigentwist.runtime import ccompile
from eigentwist.runtime.levenberg_marquardt import LAMBDA0, MAX_STEP
from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

from .c_signatures import check


def doubles(address, count=1):
    return np.ctypeslib.as_array((ctypes.c_double * count).from_address(address))


class Newton:
    """``rc et_newton_lm(n, closure, block, n_in, in, stride, q_of, legs, rows, nq, q, norm, iterations,
    tol, lambda0, max_step)``: q[i, l, j] += (sum over the other inputs k of (k + 1) x_k(i)) +
    rows; norm[i, l] = l + iterations + tol."""

    def __init__(self, rc=0):
        self.calls = []
        self.rc = rc

    def __call__(
        self, n, closure, block, n_in, ins, strides, q_of, legs, rows, nq, q, norm, iterations, tol, lam, step
    ):
        self.calls.append(
            dict(n=n, closure=closure, block=block, n_in=n_in, q_of=list(q_of)[: max(n_in, 1)], legs=legs)
        )
        self.calls[-1].update(rows=rows, nq=nq, iterations=iterations, tol=tol, lam=lam, step=step)
        self.calls[-1].update(q=q, norm=norm, sizes=(len(ins), len(strides)))
        for i in range(n):
            x = sum((k + 1) * doubles(ins[k] + 8 * strides[k] * i)[0] for k in range(n_in) if q_of[k] < 0)
            doubles(q + 8 * legs * nq * i, legs * nq)[:] += x + rows
            doubles(norm + 8 * legs * i, legs)[:] = np.arange(legs) + iterations + tol
        return self.rc


@pytest.fixture
def newton(monkeypatch):
    fn = Newton()
    monkeypatch.setattr(clm, "driver", lambda: fn)
    return fn


def run(n, threads=1, legs=2, nq=3):
    """Inputs: a joint coordinate (q_of 4), a per-pose array, a scalar (stride 0), a column of
    an (n, 3) array (stride 3)."""
    per_pose = np.arange(n) * 1.0
    scalar = np.array([0.5])
    table = np.column_stack([np.zeros(n), 100.0 + np.arange(n), np.zeros(n)])
    q = np.arange(n * legs * nq, dtype=float).reshape(n, legs, nq)
    addresses = [0, per_pose.ctypes.data, scalar.ctypes.data, table.ctypes.data + 8]
    q_out, norm = clm.iterate(1234, None, [4, -1, -1, -1], addresses, [0, 1, 0, 3], q, 5, 7, 1e-9, threads=threads)
    x = 2 * per_pose + 3 * 0.5 + 4 * (100.0 + np.arange(n)) + 5
    return q, q_out, norm, x


def test_each_poses_inputs_reach_it(newton):
    q, q_out, norm, x = run(5)
    assert np.array_equal(q_out, q + x[:, None, None]) and q_out is not q
    assert np.array_equal(q, np.arange(30.0).reshape(5, 2, 3))  # the start is not changed
    assert np.array_equal(norm, np.broadcast_to(np.arange(2) + 7 + 1e-9, (5, 2)))
    (call,) = newton.calls
    assert (call["n"], call["closure"], call["n_in"], call["q_of"]) == (5, 1234, 4, [4, -1, -1, -1])
    assert (call["legs"], call["rows"], call["nq"], call["iterations"]) == (2, 5, 3, 7)
    assert (call["tol"], call["lam"], call["step"]) == (1e-9, LAMBDA0, MAX_STEP)
    assert call["q"] == q_out.ctypes.data and call["norm"] == norm.ctypes.data
    assert type(call["iterations"]) is int and type(call["tol"]) is float


def test_the_first_damping_is_passed_as_given(newton):
    """``lambda0`` (a predicted start's first damping) reaches the driver as a double; the
    default is LAMBDA0."""
    q = np.zeros((2, 1, 3))
    clm.iterate(1234, None, [0], [0], [0], q, 3, 7, 1e-9, lambda0=1e-8)
    clm.iterate(1234, None, [0], [0], [0], q, 3, 7, 1e-9)
    assert [c["lam"] for c in newton.calls] == [1e-8, LAMBDA0]


def test_ranges_of_blocks_on_threads(newton):
    """Two threads' worth of blocks: ranges of whole blocks, each moved to its first pose."""
    n = 2 * MIN_BLOCKS_PER_THREAD * clm.BLOCK
    q, q_out, norm, x = run(n, threads=2, legs=1, nq=1)
    assert len(newton.calls) > 1 and sum(c["n"] for c in newton.calls) == n
    assert np.array_equal(q_out, q + x[:, None, None])
    assert np.array_equal(norm, np.full((n, 1), 7 + 1e-9))
    starts = sorted((c["q"] - q_out.ctypes.data) // 8 for c in newton.calls)
    assert starts[0] == 0 and all(s % clm.BLOCK == 0 for s in starts)
    assert sorted((c["norm"] - norm.ctypes.data) // 8 for c in newton.calls) == starts
    for threads in (1, None):  # one thread unless asked: one call
        newton.calls.clear()
        per_pose = np.zeros(n)
        clm.iterate(
            1, None, [-1], [per_pose.ctypes.data], [1], np.zeros((n, 1, 1)), 1, 1, 1.0, *[threads][: threads or 0]
        )
        assert [c["n"] for c in newton.calls] == [n]


@pytest.mark.parametrize("q", [np.arange(6).reshape(2, 1, 3), np.asfortranarray(np.arange(6.0).reshape(2, 3, 1))])
def test_the_start_is_copied_to_c_ordered_doubles(newton, q):
    """Integer or Fortran-ordered starting coordinates: the driver reads C-ordered doubles."""
    q_out, _ = clm.iterate(1, None, [], [], [], q, 2, 1, 1.0)
    assert q_out.dtype == np.float64 and q_out.flags.c_contiguous
    assert np.array_equal(q_out, q + 2.0)


def test_no_inputs_but_the_coordinates(newton):
    """A closure of joint coordinates alone, or of nothing: tables of one entry (never empty)."""
    q = np.zeros((2, 1, 1))
    q_out, norm = clm.iterate(1, None, [], [], [], q, 1, 3, 0.5)
    assert newton.calls[0]["n_in"] == 0 and newton.calls[0]["sizes"] == (1, 1)
    assert newton.calls[0]["q_of"] == [0]
    assert np.array_equal(q_out, np.ones((2, 1, 1))) and np.array_equal(norm, np.full((2, 1), 3.5))


def test_a_failing_driver_raises(monkeypatch):
    monkeypatch.setattr(clm, "driver", lambda: Newton(rc=-2))
    with pytest.raises(RuntimeError) as err:
        clm.iterate(1, None, [], [], [], np.zeros((1, 1, 1)), 1, 1, 1.0)
    assert str(err.value) == "C Newton iterations returned -2"


class Library:
    def __init__(self):
        self.et_newton_lm = type("CFunction", (), {})()


def test_driver_declares_the_c_signature_and_is_built_once(monkeypatch):
    built = []

    def load(source, name):
        built.append((source, name))
        return Library()

    monkeypatch.setattr(clm, "_DRIVER", [])
    monkeypatch.setattr(clm, "_LIBRARIES", [])
    monkeypatch.setattr(ccompile, "load_library", load)
    fn = clm.driver()
    check(clm.SOURCE, "et_newton_lm", fn.argtypes, fn.restype)
    assert clm.driver() is fn and built == [(clm.SOURCE, "newton")]
    assert len(clm._LIBRARIES) == 1 and clm._LIBRARIES[0].et_newton_lm is fn  # kept loaded
    # no compiler: None, and not tried again
    monkeypatch.setattr(clm, "_DRIVER", [])
    monkeypatch.setattr(clm, "_LIBRARIES", [])
    monkeypatch.setattr(ccompile, "load_library", lambda *a: built.append(a))
    assert clm.driver() is None and clm.driver() is None and len(built) == 2
    assert clm._LIBRARIES == []


def test_the_block_is_the_sources():
    assert f"#define B {clm.BLOCK}\n" in clm.SOURCE


def test_followers_driver_declares_its_c_signature():
    from .conftest import skip_tier

    fn = clm.followers_driver()
    if fn is None:
        skip_tier("compiled", "no C compiler: the driver is not built")
    check(clm.SOURCE, "et_followers_lm", fn.argtypes, fn.restype)


class Followers:
    """``rc et_followers_lm(n, kernel, block, n_in, in, stride, role, nf, followers, rows, full, q,
    norm, iterations, tol, lambda0, max_step)``: q[i, f] += (sum over the inputs k read at
    their addresses of (k + 1) x_k(i)) + full[i, followers[f]] + rows; norm[i] = iterations + tol."""

    def __init__(self):
        self.calls = []

    def __call__(
        self, n, kernel, block, n_in, ins, strides, role, nf, followers, rows, full, q, norm, its, tol, lam, step
    ):
        self.calls.append(dict(n=n, kernel=kernel, block=block, n_in=n_in, role=list(role)[:n_in], nf=nf, rows=rows))
        self.calls[-1].update(followers=list(followers)[:nf], full=full, q=q, norm=norm, its=its, tol=tol)
        self.calls[-1].update(lam=lam, step=step)
        for i in range(n):
            x = sum((k + 1) * doubles(ins[k] + 8 * strides[k] * i)[0] for k in range(n_in) if role[k] < 0)
            pose = doubles(full + 8 * 6 * i, 6)
            doubles(q + 8 * nf * i, nf)[:] += x + pose[list(followers)[:nf]] + rows
            doubles(norm + 8 * i)[:] = its + tol
        return 0


def test_followers_driver_gets_each_poses_inputs_and_its_full_pose(monkeypatch):
    fn = Followers()
    monkeypatch.setattr(clm, "followers_driver", lambda: fn)
    n = 2 * MIN_BLOCKS_PER_THREAD * clm.BLOCK + 5
    per_pose = np.arange(n) * 1.0
    scalar = np.array([0.5])
    full = np.arange(6.0 * n).reshape(n, 6)
    q = np.arange(2.0 * n).reshape(n, 1, 2)
    args = (4321, 8765, [0, -1, 7, -1], [0, per_pose.ctypes.data, 0, scalar.ctypes.data], [0, 1, 0, 0], [1, 5])
    for threads in (1, 2):
        fn.calls.clear()
        q_out, norm = clm.follow(*args, full, q, 3, 9, 1e-10, threads=threads)
        x = 2 * per_pose + 4 * 0.5
        assert np.array_equal(q_out[:, 0], q[:, 0] + x[:, None] + full[:, [1, 5]] + 3)
        assert q_out.shape == (n, 1, 2) and norm.shape == (n, 1) and np.all(norm == 9 + 1e-10)
        assert (len(fn.calls) > 1) == (threads == 2) and sum(c["n"] for c in fn.calls) == n
        call = fn.calls[0]
        assert (call["kernel"], call["block"], call["n_in"], call["role"]) == (4321, 8765, 4, [0, -1, 7, -1])
        assert (call["nf"], call["rows"]) == (2, 3)
        assert call["followers"] == [1, 5] and (call["its"], call["tol"]) == (9, 1e-10)
        assert (call["lam"], call["step"]) == (LAMBDA0, MAX_STEP)
    assert np.array_equal(q, np.arange(2.0 * n).reshape(n, 1, 2))  # the start is not changed
    # one thread unless asked; integer and Fortran-ordered starts and poses: C-ordered doubles
    fn.calls.clear()
    qi = np.asfortranarray(np.arange(2 * n).reshape(n, 1, 2))
    q_out, _ = clm.follow(*args, full.astype(int), qi, 3, 9, 1e-10)
    assert len(fn.calls) == 1 and np.array_equal(q_out[:, 0], qi[:, 0] + x[:, None] + full[:, [1, 5]] + 3)


def test_followers_driver_failure_is_named(monkeypatch):
    def fails(*args):
        return -2

    monkeypatch.setattr(clm, "followers_driver", lambda: fails)
    with pytest.raises(RuntimeError) as err:
        clm.follow(1, None, [-1], [np.zeros(1).ctypes.data], [0], [0], np.zeros((1, 6)), np.zeros((1, 1, 1)), 1, 1, 1.0)
    assert str(err.value) == "C follower iterations returned -2"


def test_followers_driver_is_bound_once_from_the_newton_library(monkeypatch):
    from eigentwist.runtime import ccompile

    class Lib:
        et_newton_lm = ctypes.CFUNCTYPE(ctypes.c_int)(lambda: 0)
        et_followers_lm = ctypes.CFUNCTYPE(ctypes.c_int)(lambda: 0)

    seen = []
    monkeypatch.setattr(clm, "_DRIVER", [])
    monkeypatch.setattr(clm, "_FOLLOWERS", [])
    monkeypatch.setattr(clm, "_LIBRARIES", [])
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: seen.append(name) or Lib())
    fn = clm.followers_driver()
    assert fn is Lib.et_followers_lm and clm.followers_driver() is fn and seen == ["newton"]
    check(clm.SOURCE, "et_followers_lm", fn.argtypes, fn.restype)
    monkeypatch.setattr(clm, "_DRIVER", [])
    monkeypatch.setattr(clm, "_FOLLOWERS", [])
    monkeypatch.setattr(clm, "_LIBRARIES", [])
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: None)
    assert clm.followers_driver() is None and clm._FOLLOWERS == [None]


def test_the_closures_block_function_reaches_the_driver(newton):
    clm.iterate(1234, 5678, [], [], [], np.zeros((3, 1, 1)), 1, 1, 1.0)
    clm.iterate(1234, None, [], [], [], np.zeros((3, 1, 1)), 1, 1, 1.0)
    assert [(c["closure"], c["block"]) for c in newton.calls] == [(1234, 5678), (1234, None)]
