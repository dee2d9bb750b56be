"""The prepared fused pass (:class:`eigentwist.runtime.fused_call.FusedCall`) on a stand-in of the
library's C function written here in Python: it reads each input through the table of addresses
and strides it is given (as the generated C does: ``input k of pose i`` at ``address_k + 8 stride_k
i``) and writes the outputs through the addresses it is given. What the stand-in writes is a known
function of the inputs, so each pose's results say which values reached it. No compile.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from eigentwist.runtime.errors import InputError
from eigentwist.runtime.fused_call import FusedCall
from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

NAMES = ["x", "a", "y", "b", "z"]
DIM = 3


@pytest.fixture(autouse=True)
def by_ranges(monkeypatch):
    """The stand-ins here are Python callables, not C functions: the pass's blocks run by
    ranges from Python (the scheduler in C is tested on C functions: tests/test_parallel_screen.py,
    tests/test_fast_paths.py)."""
    from eigentwist.runtime import c_schedule

    monkeypatch.setattr(c_schedule, "scheduler", lambda: None)


def read(address, count=1):
    return np.ctypeslib.as_array((ctypes.c_double * count).from_address(address))


class CPass:
    """``rc fn(begin, end, ins, strides, model, _, mats, _, freq, vecs, status, opts)``:
    freq[i, j] = x + 10 y + 100 z + a (j + 1) + b model; status[i] = i % 3; every matrix
    entry of pose i = i + its index in the table; eigentwists[i] = i times the identity."""

    def __init__(self, rc=0):
        self.argtypes = None
        self.restype = None
        self.ranges = []
        self.rc = rc

    def __call__(self, begin, end, ins, strides, model, unused1, mats, unused2, freq, vecs, status, opts):
        assert unused1 is None and unused2 is None
        assert mats is None or isinstance(mats, ctypes.Array)  # NULL where no matrix is asked for
        self.ranges.append((begin, end))
        self.addresses = (freq, vecs, status)
        self.opts = opts
        for i in range(begin, end):
            v = {name: read(ins[k] + 8 * strides[k] * i)[0] for k, name in enumerate(NAMES)}
            out = read(freq + 8 * DIM * i, DIM)
            out[:] = v["x"] + 10 * v["y"] + 100 * v["z"] + v["a"] * np.arange(1, DIM + 1) + v["b"] * model
            np.ctypeslib.as_array((ctypes.c_int8 * 1).from_address(status + i))[0] = i % 3
            if vecs is not None:
                read(vecs + 8 * DIM * DIM * i, DIM * DIM)[:] = (i * np.eye(DIM)).ravel()
            if mats is not None:
                for k, address in enumerate(mats):
                    if address:
                        read(address + 8 * 4 * i, 4)[:] = i + k
        return self.rc


def prepared(fn=None, p=None, pose_inputs=None, vectors=False, matrices=(4, ()), block=2, checked=None):
    checked = [] if checked is None else checked
    call = FusedCall(
        fn or CPass(),
        NAMES,
        {"a": 2.0, "b": np.array(0.5)} if p is None else p,
        {"x": 3, "y": 3, "z": 3, "w": 3} if pose_inputs is None else pose_inputs,
        model_id=2,
        dim=DIM,
        vectors=vectors,
        matrices=matrices,
        options=lambda: "the options",
        block=block,
        check=lambda rc, what: checked.append((rc, what)),
    )
    return call, checked


def test_scalars_and_pose_inputs():
    fn = CPass()
    call, _ = prepared(fn)
    assert call.pose_inputs == ("x", "y", "z") and call.at == [0, 2, 4]  # "w": not read by the pass, dropped
    assert list(call.scalars) == [0.0, 2.0, 0.0, 0.5, 0.0] and not call.scalars.flags.writeable
    base = call.scalars.ctypes.data
    assert list(call.addresses) == [base + 8 * k for k in range(5)]
    assert list(call.strides) == [3, 0, 3, 0, 3]
    assert fn.restype is ctypes.c_int and len(fn.argtypes) == 12
    assert fn.argtypes[:5] == [ctypes.c_int64, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int]
    assert fn.argtypes[5:] == [ctypes.c_void_p] * 7
    assert (call.model_id, call.dim, call.block) == (2, DIM, 2) and call.options() == "the options"


@pytest.mark.parametrize("value, size", [(np.array([1.0, 2.0]), 2), (np.zeros((1, 2)), 2), (np.array([]), 0)])
def test_an_input_per_pose_is_refused(value, size):
    with pytest.raises(InputError) as err:
        prepared(p={"a": value, "b": 1.0})
    assert str(err.value) == f"input 'a': expected one value for a prepared pass, got {size}"
    call, _ = prepared(p={"a": np.ones((1, 1)), "b": [[4.0]]})  # one value in any shape
    assert list(call.scalars) == [0.0, 1.0, 0.0, 4.0, 0.0]


def poses(n):
    return np.column_stack([np.arange(n) * 0.1, np.arange(n) * 0.01 + 1.0, np.full(n, -2.0)])


def expected_freq(P, a=2.0, b=0.5, model=2):
    return P[:, :1] + 10 * P[:, 1:2] + 100 * P[:, 2:3] + a * np.arange(1, DIM + 1) + b * model


def test_a_call_reads_each_poses_coordinates():
    fn = CPass()
    call, checked = prepared(fn, block=4)
    P = poses(3)
    out = call([P.ctypes.data + 8 * k for k in range(3)], 3, 1)  # x, y, z of pose i: 3 doubles apart
    assert sorted(out) == ["freq_hz", "status"]
    assert np.allclose(out["freq_hz"], expected_freq(P), rtol=1e-15)
    assert out["status"].dtype == np.int8 and out["status"].tolist() == [0, 1, 2]
    assert fn.ranges == [(0, 3)] and checked == [(0, "fused")] and fn.opts == "the options"
    assert fn.addresses == (out["freq_hz"].ctypes.data, None, out["status"].ctypes.data)  # no eigentwists: NULL
    # another call on other poses: the prepared table is not changed by the first
    Q = poses(2)[::-1].copy()
    out = call([Q.ctypes.data + 8 * k for k in range(3)], 2, 1)
    assert np.allclose(out["freq_hz"], expected_freq(Q), rtol=1e-15)
    assert list(call.addresses) == [call.scalars.ctypes.data + 8 * k for k in range(5)]


def test_vectors_and_matrices_asked_for():
    fn = CPass()
    call, _ = prepared(fn, vectors=True, matrices=(4, ((1, "M", (2, 2)), (3, "K_F", (4,)))), block=8)
    P = poses(3)
    out = call([P.ctypes.data + 8 * k for k in range(3)], 3, 1)
    assert sorted(out) == ["K_F", "M", "eigentwists", "freq_hz", "status"]
    assert out["M"].shape == (3, 2, 2) and out["K_F"].shape == (3, 4) and out["eigentwists"].shape == (3, DIM, DIM)
    assert np.array_equal(out["M"], np.arange(3)[:, None, None] + np.ones((3, 2, 2)))  # table slot 1
    assert np.array_equal(out["K_F"], np.arange(3)[:, None] + np.full((3, 4), 3.0))  # table slot 3
    assert np.array_equal(out["eigentwists"], np.arange(3)[:, None, None] * np.eye(DIM))
    assert fn.addresses == tuple(out[k].ctypes.data for k in ("freq_hz", "eigentwists", "status"))


def test_ranges_of_blocks_on_threads_and_every_return_code_checked():
    """More poses than a block: ranges of whole blocks, on threads where the batch has at least
    MIN_BLOCKS_PER_THREAD blocks a thread; each range's return code checked."""
    block = 2
    n = 2 * MIN_BLOCKS_PER_THREAD * block  # two threads' worth
    fn = CPass(rc=7)
    call, checked = prepared(fn, block=block)
    P = poses(n)
    out = call([P.ctypes.data + 8 * k for k in range(3)], n, 2)
    assert np.allclose(out["freq_hz"], expected_freq(P), rtol=1e-15)
    ranges = sorted(fn.ranges)
    assert len(ranges) > 1 and ranges[0][0] == 0 and ranges[-1][1] == n
    assert all(a % block == 0 for a, _ in ranges) and all(b == c for (_, b), (c, _) in zip(ranges, ranges[1:]))
    assert checked == [(7, "fused")] * len(ranges)
    # fewer blocks than two threads' worth: one call on this thread; a batch of one block: one call
    for m, threads in ((n, 1), ((2 * MIN_BLOCKS_PER_THREAD - 1) * block, 2), (block, 4)):
        fn = CPass()
        call, checked = prepared(fn, block=block)
        P = poses(m)
        call([P.ctypes.data + 8 * k for k in range(3)], m, threads)
        assert fn.ranges == [(0, m)] and checked == [(0, "fused")], (m, threads)
    fn = CPass()
    call, checked = prepared(fn, block=block)
    P = poses(block + 1)
    call([P.ctypes.data + 8 * k for k in range(3)], block + 1, 1)
    assert fn.ranges == [(0, block + 1)]
