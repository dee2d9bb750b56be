"""The Python side of the C kernels (:mod:`eigentwist.runtime.c_kernels`) on a stand-in library
written here: its kernels read each pose's inputs through the tables of addresses and strides they
are given (input k of pose i at ``address_k + 8 stride_k i``, as the generated C does) and write a
known function of them, so each pose's results say which values reached it. No compile.
"""

from __future__ import annotations

import ctypes
import functools
import json
import re
import subprocess
import types

import numpy as np
import pytest

from eigentwist.errors import InputError
from eigentwist.runtime import c_kernels as ck
from eigentwist.runtime.errors import SingularPoseError, UnreachablePoseError
from eigentwist.runtime.validity import STATUS


@pytest.fixture(autouse=True)
def by_ranges(monkeypatch):
    """The stand-ins here are Python callables, not C functions: the pass's blocks run by
    ranges from Python (the scheduler in C is tested on C functions: tests/test_parallel_screen.py,
    tests/test_fast_paths.py)."""
    from eigentwist.runtime import c_schedule

    monkeypatch.setattr(c_schedule, "scheduler", lambda: None)


@functools.cache
def heli4_source() -> str:
    return ck.source_path("heli4").read_text()


def doubles(address, count=1):
    return np.ctypeslib.as_array((ctypes.c_double * count).from_address(address))


SIGNATURE = {
    "robot": "toy",
    "source_hash": "abc",
    "block": 4,
    "kernels": {
        "inverse_kinematics": {"function": "et_toy_ik", "inputs": [], "outputs": [["q", [2, 3]]]},
        "matrices": {
            "function": "et_toy_matrices",
            "inputs": [["param", "a", None], ["q", "q_1_2", [1, 2]], ["param", "b", None], ["q", "q_0_1", [0, 1]]],
            "outputs": [["M", [2, 2]], ["s", []]],
        },
        "jacobians": {"function": "et_toy_jac", "inputs": [], "outputs": [["J_rows", [2]]]},
        **{
            kernel: {
                "function": f"et_toy_{kernel}",
                "inputs": [["param", "a", None], ["q", "q_1_2", [1, 2]], ["param", "b", None], ["q", "q_0_1", [0, 1]]],
                "outputs": [["M", [2, 2]], ["s", []]],
            }
            for kernel in ("gravity", "legs", "loop_closure", "more")
        },
        "ik": {
            "function": "et_toy_ik2",
            "inputs": [["param", "a", None], ["pose", "x", None], ["pose", "y", None], ["pose", "z", None]],
            "outputs": [["M", [2, 2]], ["s", []], ["q", [2, 3]]],
        },
    },
    "fused": {"function": "et_toy_fused", "matrices": [["M", [2, 2]]], "inputs": [], "status": STATUS, "models": []},
    "eigh": {"function": "et_toy_eigh", "dims": [2, 3]},
}


class Matrices:
    """M[i] = [[a, q_1_2], [b, q_0_1]], s[i] = a + b + q_1_2 + q_0_1, pose i's values."""

    def __init__(self, rc=0):
        self.rc = rc
        self.calls = []

    def __call__(self, n, addresses, strides, outs):
        self.calls.append((n, [addresses[k] for k in range(4)], [strides[k] for k in range(4)]))
        for i in range(n):
            a, q12, b, q01 = (doubles(addresses[k] + 8 * strides[k] * i)[0] for k in range(4))
            doubles(outs[0] + 32 * i, 4)[:] = [a, q12, b, q01]
            doubles(outs[1] + 8 * i)[0] = a + b + q12 + q01
        return self.rc


class Library:
    def __init__(self, matrices):
        for name in ("et_toy_ik", "et_toy_jac", "et_toy_fused", "et_toy_eigh"):
            setattr(self, name, type("CFunction", (), {})())
        self.et_toy_matrices = matrices
        for kernel in ("gravity", "legs", "loop_closure", "more", "ik2"):
            setattr(self, f"et_toy_{kernel}", Matrices())

    def __getitem__(self, name):  # ctypes: a new function object of that name
        return ("a new function object", name)


def kernels(matrices=None, signature=SIGNATURE):
    return ck.CKernels(Library(matrices or Matrices()), signature, ck.Build("lib.so", "portable", []))


def test_a_kernel_reads_each_poses_parameters_and_joint_coordinates():
    fn = Matrices()
    kern = kernels(fn)
    q = np.arange(2 * 2 * 3, dtype=float).reshape(2, 2, 3)
    out = kern.matrices(q, {"a": np.array([1.0, 2.0]), "b": 7.0, "c": "unused"})
    assert sorted(out) == ["M", "s"] and out["M"].shape == (2, 2, 2) and out["s"].shape == (2,)
    want_M = np.array([[[1.0, q[0, 1, 2]], [7.0, q[0, 0, 1]]], [[2.0, q[1, 1, 2]], [7.0, q[1, 0, 1]]]])
    assert np.array_equal(out["M"], want_M)
    assert np.array_equal(out["s"], want_M.reshape(2, 4).sum(axis=1))
    n, addresses, strides = fn.calls[0]
    assert n == 2 and strides == [1, 6, 0, 6]  # a per pose, q rows of 6, b a scalar
    # broadcasting: q of one pose, a per pose
    out = kern.matrices(q[0], {"a": np.array([[1.0], [3.0]]), "b": 7.0})
    assert out["M"].shape == (2, 1, 2, 2) and np.array_equal(out["M"][1, 0, 0], [3.0, q[0, 1, 2]])
    assert kern.matrices(np.zeros((0, 2, 3)), {"a": 1.0, "b": 2.0})["M"].shape == (0, 2, 2)
    assert len(fn.calls) == 2  # no call for no pose


@pytest.mark.parametrize("shape", [(3, 2), (4, 3, 3), (2, 2, 4), (6,)])
def test_joint_coordinates_of_another_shape_are_refused(shape):
    with pytest.raises(InputError) as err:
        kernels().matrices(np.zeros(shape), {"a": 1.0, "b": 2.0})
    if len(shape) >= 2:
        assert str(err.value) == f"q has shape {shape}: expected (..., 2, 3) joint coordinates"


def test_the_scalars_of_a_call_are_packed_once_for_the_same_objects():
    fn = Matrices()
    kern = kernels(fn)
    a, b = 1.5, np.float64(2.5)
    q = np.zeros((3, 2, 3))
    kern.matrices(q, {"a": a, "b": b})
    packed = kern._kernel_packed["matrices"]
    out = kern.matrices(q, {"a": a, "b": b})
    assert kern._kernel_packed["matrices"] is packed and np.array_equal(out["s"], np.full(3, 4.0))
    out = kern.matrices(q, {"a": 3.0, "b": b})  # another object: packed again, its value read
    assert kern._kernel_packed["matrices"] is not packed and np.array_equal(out["s"], np.full(3, 5.5))


def test_a_failing_kernel_raises():
    with pytest.raises(RuntimeError) as err:
        kernels(Matrices(rc=3)).matrices(np.zeros((1, 2, 3)), {"a": 1.0, "b": 2.0})
    assert str(err.value) == "C matrices returned 3"
    with pytest.raises(MemoryError) as err:
        kernels(Matrices(rc=-2)).matrices(np.zeros((1, 2, 3)), {"a": 1.0, "b": 2.0})
    assert str(err.value) == "C matrices: out of memory for its block buffers"


def test_inputs_scalars_share_one_array_and_columns_are_read_in_place():
    keep = []
    table = np.arange(12.0).reshape(4, 3)
    per_pose = np.arange(4.0) + 0.5
    values = [2.0, table[:, 1], per_pose, np.array([1, 2, 3, 4]), table[::-1, 0], np.int64(3)]
    addresses, strides = ck._inputs(values, (4,), keep)
    assert strides == [0, 3, 1, 1, 1, 0]
    assert addresses[1] == table.ctypes.data + 8 and addresses[2] == per_pose.ctypes.data
    assert addresses[5] - addresses[0] == 8 * 5  # the scalars side by side in one array
    for k, v in enumerate(values):
        want = np.broadcast_to(np.asarray(v, dtype=float), (4,))
        got = [doubles(addresses[k] + 8 * strides[k] * i)[0] for i in range(4)]
        assert np.array_equal(got, want), k


def test_fixed_values_are_immutable_scalars():
    frozen = np.array(2.0)
    frozen.flags.writeable = False
    assert ck._fixed(1.0) and ck._fixed(3) and ck._fixed(np.float64(1.0)) and ck._fixed(frozen)
    writeable = np.array(2.0)
    view = np.array([2.0])[0:1].reshape(())
    view.flags.writeable = False
    f32 = np.array(2.0, dtype=np.float32)
    f32.flags.writeable = False
    assert not any(map(ck._fixed, [writeable, view, f32, np.float32(1.0), [1.0], np.ones(2), True]))


def test_packed_matches_the_same_objects_at_the_same_positions():
    a, b = 1.0, 2.5
    arr = np.ones(3)
    p = ck._Packed([a, arr, b])
    assert p.fixed == [0, 2] and p.others == [1] and p.at.tolist() == [1]
    assert list(p.packed) == [1.0, 2.5] and p.addresses[0] == p.packed.ctypes.data and p.addresses[1] is None
    assert p.addresses[2] == p.packed.ctypes.data + 8 and list(p.strides) == [0, 0, 0]
    assert p.array.tolist() == [p.packed.ctypes.data, 0, p.packed.ctypes.data + 8]
    assert p.matches([a, np.zeros(3), b]) and not p.matches([2.0, arr, b]) and not p.matches([a, arr, b, b])


def test_packed_renewed_reads_only_the_new_objects_and_keeps_the_old_table():
    a, b = 1.0, 2.5
    arr = np.ones(3)
    p = ck._Packed([a, arr, b])
    c = np.array(4.0)
    c.flags.writeable = False
    r = p.renewed([c, np.zeros(3), b])  # a fit's new value at a fixed position
    assert r is not None and r.fixed == [0, 2] and r.others == [1] and r.matches([c, arr, b])
    assert list(r.packed) == [4.0, 2.5] and list(p.packed) == [1.0, 2.5]  # the old table as it was
    fresh = ck._Packed([c, arr, b])
    base = r.packed.ctypes.data
    assert r.array.tolist() == [base, 0, base + 8] and [r.addresses[i] for i in range(3)] == [base, None, base + 8]
    assert list(r.strides) == list(fresh.strides) and list(r.packed) == list(fresh.packed)
    writeable = np.array(4.0)  # not fixed: the layout does not hold, pack anew
    assert p.renewed([writeable, arr, b]) is None and p.renewed([a, arr]) is None
    assert ck._repacked(p, [writeable, arr, b]).fixed == [2] and ck._repacked(None, [a, arr, b]).fixed == [0, 2]


def test_the_c_tables_have_at_least_one_entry():
    assert len(ck._ptrs([])) == 1 and len(ck._strides([])) == 1
    assert list(ck._strides([3, 0])) == [3, 0] and ck._ptrs([5, 0])[0] == 5


def test_generalized_eigh_refuses_other_shapes():
    kern = kernels()
    for K, M in ((np.zeros((1, 4, 4)), np.zeros((1, 4, 4))), (np.zeros((1, 2, 2)), np.zeros((1, 3, 3)))):
        with pytest.raises(InputError) as err:
            kern.generalized_eigh(K, M)
        assert str(err.value) == (f"K {K.shape} and M {M.shape}: expected equal shapes (N, n, n) with n in [2, 3]")
    with pytest.raises(InputError):
        kern.generalized_eigh(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(InputError):
        kern.generalized_eigh(np.zeros((1, 2, 3)), np.zeros((1, 2, 3)))


class Eigh:
    """lam[i] = diag(K[i]) / diag(M[i]), sorted; V = identity; NaN where M's diagonal is 0."""

    def __init__(self):
        self.calls = []

    def __call__(self, n, dim, K, M, lam, V):
        self.calls.append((n, dim, V is None))
        for i in range(n):
            k = doubles(K + 8 * dim * dim * i, dim * dim).reshape(dim, dim)
            m = doubles(M + 8 * dim * dim * i, dim * dim).reshape(dim, dim)
            with np.errstate(divide="ignore", invalid="ignore"):
                doubles(lam + 8 * dim * i, dim)[:] = np.sort(np.diag(k) / np.diag(m))
            if V is not None:
                doubles(V + 8 * dim * dim * i, dim * dim)[:] = np.eye(dim).ravel()
        return 0


def test_generalized_eigh_on_blocks_and_a_bad_pair():
    kern = kernels()
    fn = Eigh()
    kern._fn["eigh"] = fn
    K = np.stack([np.diag([3.0, 1.0, 2.0]) * (k + 1) for k in range(5)])
    M = np.broadcast_to(np.eye(3), (5, 3, 3))
    lam, V = kern.generalized_eigh(K, M)
    assert np.array_equal(lam, np.stack([np.array([1.0, 2.0, 3.0]) * (k + 1) for k in range(5)]))
    assert V.shape == (5, 3, 3) and np.array_equal(V[4], np.eye(3)) and fn.calls == [(5, 3, False)]
    lam, V = kern.generalized_eigh(K, M, vectors=False)
    assert V is None and fn.calls[-1] == (5, 3, True)
    M = np.array(M)
    M[3] = 0.0
    with pytest.raises(np.linalg.LinAlgError) as err:
        kern.generalized_eigh(K, M)
    assert str(err.value) == "pair 3: M is not positive definite (or K, M are not finite)"


def test_generalized_eigh_post_runs_on_each_range_once_after_its_solve():
    kern = kernels()
    kern._fn["eigh"] = Eigh()
    n = 3 * kern.BLOCK * 16 + 5  # three threads' worth of blocks (threads.MIN_BLOCKS_PER_THREAD)
    K = np.stack([np.diag([3.0, 1.0, 2.0]) * (k + 1) for k in range(n)])
    M = np.broadcast_to(np.eye(3), (n, 3, 3))
    seen, copies = [], np.full((n, 3), np.nan)

    def post(lam, V, rows):
        seen.append((rows.start, rows.stop))
        copies[rows] = lam[rows]  # the range's eigenvalues are there when post runs

    lam, _ = kern.generalized_eigh(K, M, threads=3, post=post)
    seen.sort()
    assert len(seen) > 1 and seen[0][0] == 0 and seen[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(seen, seen[1:]))  # every row once, no gap
    assert np.array_equal(copies, lam)
    M = np.array(M)
    M[7] = 0.0  # a pair that fails: post still runs on the solved rows, then the error
    with pytest.raises(np.linalg.LinAlgError, match="pair 7: M is not positive definite"):
        kern.generalized_eigh(K, M, post=post)


def test_the_librarys_status_codes_must_be_pythons():
    sig = dict(SIGNATURE, fused=dict(SIGNATURE["fused"], status={"ok": 0}))
    with pytest.raises(RuntimeError) as err:
        kernels(signature=sig)
    assert "has status codes {'ok': 0}" in str(err.value) and "run `eigentwist generate`" in str(err.value)


def test_fused_options_read_the_tolerances_when_asked(monkeypatch):
    from eigentwist.runtime import eigen, validity

    kern = kernels()
    opts = kern.fused_options(True)
    assert list(opts) == [validity.LEVER_TOL, -1.0, eigen.ROUNDOFF_EPS, 1.0] and kern.fused_options(True) is opts
    assert list(kern.fused_options(False))[3] == 0.0
    monkeypatch.setattr(validity, "LEVER_TOL", 0.25)
    assert list(kern.fused_options(True))[0] == 0.25
    sig = dict(SIGNATURE, fused=dict(SIGNATURE["fused"], inputs=[["param", "x"], ["param", validity.LEVER_SCALE]]))
    assert list(kernels(signature=sig).fused_options(False))[1] == 1.0  # the lever scale's input


def test_kernel_arguments_for_a_driver(monkeypatch):
    kern = kernels()
    monkeypatch.setattr(ck.CKernels, "address", lambda self, name: ("address of", name))
    address, inputs, strides, q_of, outs, keep = kern.kernel_arguments("matrices", {"a": 2.0, "b": np.ones(5)}, 5)
    assert address == ("address of", "matrices")
    assert q_of.tolist() == [-1, 5, -1, 1] and q_of.dtype == np.intc  # leg * 3 + joint
    assert strides.tolist() == [0, 0, 1, 0] and inputs[1] == 0 and inputs[3] == 0
    assert doubles(int(inputs[0]))[0] == 2.0 and np.array_equal(doubles(int(inputs[2]), 5), np.ones(5))
    assert {k: v.shape for k, v in outs.items()} == {"M": (5, 2, 2), "s": (5,)}


@pytest.mark.parametrize("kernel", ["gravity", "legs", "loop_closure"])
def test_the_joint_coordinate_kernels(kernel):
    """gravity, legs and loop_closure: the kernel of that name on q and the parameters."""
    kern = kernels()
    q = np.arange(6.0).reshape(2, 3) + 1
    out = getattr(kern, kernel)(q, {"a": 2.0, "b": 3.0})
    assert np.array_equal(out["M"], [[2.0, q[1, 2]], [3.0, q[0, 1]]]) and out["s"] == 2.0 + 3.0 + q[1, 2] + q[0, 1]
    assert len(kern._lib.__dict__[f"et_toy_{kernel}"].calls) == 1


def test_a_kernel_on_threads_reads_and_writes_each_range_at_its_poses():
    """jacobians on two threads: block-aligned ranges, each call reading its poses' inputs
    (per-pose a and q, scalar b) and writing its poses' outputs; the same values as one call."""
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], jacobians=SIGNATURE["kernels"]["matrices"]))
    kern = kernels(signature=sig)
    fn = kern._lib.__dict__["et_toy_matrices"] = Matrices()
    kern._fn["jacobians"] = fn
    n = 2 * MIN_BLOCKS_PER_THREAD * kern.BLOCK + 3
    q = np.random.default_rng(0).random((n, 2, 3))
    a = np.arange(n, dtype=float)
    one = kern.jacobians(q, {"a": a, "b": 7.0})
    assert len(fn.calls) == 1 and np.array_equal(one["s"], a + 7.0 + q[:, 1, 2] + q[:, 0, 1])
    two = kern.jacobians(q, {"a": a, "b": 7.0}, threads=2)
    calls = fn.calls[1:]
    assert len(calls) > 2 and sum(c[0] for c in calls) == n
    # every range but the last is whole blocks (the threads append their calls in any order)
    assert sum(c[0] % kern.BLOCK != 0 for c in calls) == (n % kern.BLOCK != 0)
    assert np.array_equal(two["M"], one["M"]) and np.array_equal(two["s"], one["s"])


def test_no_loop_closure_kernel_no_method():
    sig = dict(SIGNATURE, kernels={k: v for k, v in SIGNATURE["kernels"].items() if k != "loop_closure"})
    with pytest.raises(AttributeError) as err:
        kernels(signature=sig).loop_closure(np.zeros((2, 3)), {})
    assert str(err.value) == "loop_closure"


def test_inverse_kinematics_broadcasts_the_pose_and_the_parameters():
    """The inputs of the "inverse_kinematics" kernel by name; here the ik2 layout (a, x, y, z)
    read as M = [[a, x], [y, z]]."""
    sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], inverse_kinematics=SIGNATURE["kernels"]["ik"]))
    kern = kernels(signature=sig)
    out = kern.inverse_kinematics(np.array([1.0, 2.0, 3.0]), 5.0, np.array([[7.0], [8.0]]), {"a": 0.5, "b": 9.0})
    assert out["M"].shape == (2, 3, 2, 2)
    assert np.array_equal(out["M"][1, 2], [[0.5, 3.0], [5.0, 8.0]]) and out["s"][0, 0] == 0.5 + 1.0 + 5.0 + 7.0


def test_newton_hands_the_closure_and_its_inputs_to_the_driver(monkeypatch):
    from eigentwist.runtime import c_levenberg_marquardt as clm

    closure = dict(SIGNATURE["kernels"]["loop_closure"], outputs=[["residual", [2, 4]], ["dresidual", [2, 4, 3]]])
    sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], loop_closure=closure))
    lib = Library(Matrices())
    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ck._PTRS, ck._I64P, ck._PTRS)
    lib.et_toy_loop_closure = proto(lambda *a: 0)  # a C function pointer: the driver gets its address
    kern = ck.CKernels(lib, sig, ck.Build("lib.so", "portable", []))
    seen, blocks = [], []

    def iterate(address, block, q_of, addresses, strides, q, rows, iterations, tol, threads):
        values = [
            doubles(a + 8 * s * i)[0] if k < 0 else None for a, s, k in zip(addresses, strides, q_of) for i in (2,)
        ]
        seen.append((address, q_of, strides, q, rows, iterations, tol, threads, values))
        blocks.append(block)
        assert [a for a, k in zip(addresses, q_of) if k >= 0] == [0, 0]  # the driver's own q: no address
        return "the driver's result"

    monkeypatch.setattr(clm, "driver", lambda: object())
    monkeypatch.setattr(clm, "iterate", iterate)
    q = np.zeros((3, 2, 3), dtype=int)
    assert kern.newton(q, {"a": np.array([1.0, 2.0, 4.0]), "b": 7.0}, 30, 1e-9, threads=2) == "the driver's result"
    address, q_of, strides, q_given, rows, iterations, tol, threads, values = seen[0]
    assert address == ctypes.cast(lib.et_toy_loop_closure, ctypes.c_void_p).value
    assert q_of == [-1, 5, -1, 1] and strides == [1, 0, 0, 0] and rows == 4
    assert values == [4.0, None, 7.0, None]  # pose 2's a, b
    assert q_given.dtype == np.float64 and q_given.shape == (3, 2, 3) and (iterations, tol, threads) == (30, 1e-9, 2)
    kern.newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9)
    assert seen[1][7] == 1
    only_q = dict(closure, inputs=[["q", "q_1_2", [1, 2]], ["q", "q_0_1", [0, 1]]])
    kern = ck.CKernels(lib, dict(sig, kernels=dict(sig["kernels"], loop_closure=only_q)), kern.build)
    kern.newton(q, {}, 30, 1e-9)  # no input but the joint coordinates
    assert seen[2][1] == [5, 1] and seen[2][2] == [0, 0] and seen[2][8] == [None, None]
    monkeypatch.setattr(clm, "driver", lambda: None)
    assert kern.newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9) is None
    monkeypatch.setattr(clm, "driver", lambda: object())
    sig = dict(SIGNATURE, kernels={k: v for k, v in SIGNATURE["kernels"].items() if k != "loop_closure"})
    assert kernels(signature=sig).newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9) is None  # no closure kernel
    assert blocks == [None, None, None]  # the signature names no block function


def test_newton_hands_the_closures_block_function_only_where_its_rows_are_the_drivers(monkeypatch):
    from eigentwist.runtime import c_levenberg_marquardt as clm

    lib = Library(Matrices())
    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ck._PTRS, ck._I64P, ck._PTRS)
    lib.et_toy_loop_closure = proto(lambda *a: 0)
    lib.et_toy_loop_closure_block_entry = proto(lambda *a: 0)
    blocks = []
    monkeypatch.setattr(clm, "driver", lambda: object())
    monkeypatch.setattr(clm, "iterate", lambda closure, block, *a: blocks.append(block))
    q = np.zeros((3, 2, 3))
    for outputs in (
        [["residual", [2, 4]], ["dresidual", [2, 4, 3]]],  # the driver's rows: the block function
        [["dresidual", [2, 4, 3]], ["residual", [2, 4]]],  # another order: the exported kernel
        [["residual", [2, 4]], ["dresidual", [2, 4, 2]]],  # another number of coordinates
    ):
        closure = dict(SIGNATURE["kernels"]["loop_closure"], outputs=outputs, block="et_toy_loop_closure_block_entry")
        sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], loop_closure=closure))
        ck.CKernels(lib, sig, ck.Build("lib.so", "portable", [])).newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9)
    assert blocks == [ctypes.cast(lib.et_toy_loop_closure_block_entry, ctypes.c_void_p).value, None, None]
    # the first damping: passed on where given, the driver's default where not
    damping = []
    monkeypatch.setattr(clm, "iterate", lambda *a, **kw: damping.append(kw.get("lambda0", a[10:11])))
    kern = ck.CKernels(lib, sig, ck.Build("lib.so", "portable", []))
    kern.newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9, lambda0=1e-8)
    kern.newton(q, {"a": 1.0, "b": 7.0}, 30, 1e-9)
    assert damping == [(1e-8,), ()]


def test_bind_declares_the_generated_c_signatures():
    """The argument types _bind declares are those of the checked-in C source's kernel, fused
    pass and eigen-solver (tests/c_signatures.py reads them from the declarations)."""
    from .c_signatures import check

    source = heli4_source()
    kern = kernels()
    check(source, "et_heli4_matrices", kern._fn["matrices"].argtypes, kern._fn["matrices"].restype)
    check(source, "et_heli4_fused", kern._fn["fused"].argtypes, kern._fn["fused"].restype)
    check(source, "et_heli4_eigh", kern._fn["eigh"].argtypes, kern._fn["eigh"].restype)
    assert kern._fn["fused"] is kern._lib.et_toy_fused and kern._fn["eigh"] is kern._lib.et_toy_eigh


def test_the_librarys_description():
    kern = kernels()
    assert (kern.ROBOT, kern.SOURCE_HASH, kern.BLOCK, kern.N_LEGS, kern.JOINTS_PER_LEG) == ("toy", "abc", 4, 2, 3)
    assert kern.FUSED_MATRICES == {"M": (2, 2)} and kern.OUTPUTS["matrices"] == {"M": (2, 2), "s": ()}
    assert repr(kern) == "<eigentwist C kernels 'toy' (portable) lib.so>"
    assert kern._rotation is False and kern._unread == set()
    names = [["param", n] for n in ("x", "R_00", "R_12")]
    assert kernels(signature=dict(SIGNATURE, fused=dict(SIGNATURE["fused"], inputs=names)))._unread == set()
    names = [["param", n] for n in ("x", "R_00", "R_12", "R_3", "RR_00")]
    sig = dict(SIGNATURE, fused=dict(SIGNATURE["fused"], inputs=names, rotation=True))
    kern = kernels(signature=sig)
    assert kern._rotation is True and kern._unread == {"R_00", "R_12"}  # computed from the rotation vector


def test_a_kernel_of_joint_coordinates_alone():
    only_q = {"function": "et_toy_more", "inputs": [["q", "q_0_0", [0, 0]]], "outputs": [["M", [2, 2]], ["s", []]]}
    sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], more=only_q))
    kern = kernels(signature=sig)
    addresses, strides = kern._kernel_inputs("more", [], (3,), [])
    assert addresses.dtype == np.uint64 and strides.dtype == np.int64 and addresses.size == strides.size == 0
    kern._fn["more"] = Kernel(1, lambda v: (np.repeat(v, 4, axis=1), 2 * v[:, 0]))
    q = np.arange(12.0).reshape(2, 2, 3)
    out = kern._q_kernel("more", q, {})
    assert np.array_equal(out["M"], [[[0.0, 0.0], [0.0, 0.0]], [[6.0, 6.0], [6.0, 6.0]]]) and out["s"].tolist() == [
        0,
        12,
    ]
    assert kern._layout("more") is kern._layout("more")  # worked out once per kernel


def test_kernel_arguments_of_a_kernel_without_joint_coordinates(monkeypatch):
    """The ik layout (a, x, y, z): no entry reads q; the tables are the uint64 addresses and
    int64 strides a C driver reads as they are."""
    kern = kernels()
    monkeypatch.setattr(ck.CKernels, "address", lambda self, name: ("address of", name))
    address, inputs, strides, q_of, outs, keep = kern.kernel_arguments(
        "ik", {"a": 1.0, "x": np.arange(3.0), "y": 2.0, "z": np.ones(3)}, 3
    )
    assert address == ("address of", "ik") and q_of.tolist() == [-1, -1, -1, -1] and strides.tolist() == [0, 1, 0, 1]
    assert inputs.dtype == np.uint64 and strides.dtype == np.int64 and "ik" in kern._kernel_packed
    assert np.array_equal(doubles(int(inputs[1]), 3), [0.0, 1.0, 2.0]) and doubles(int(inputs[2]))[0] == 2.0
    assert {k: v.shape for k, v in outs.items()} == {"M": (3, 2, 2), "s": (3,), "q": (3, 2, 3)}


FUSED = {
    "function": "et_toy_fused",
    "matrices": [["M", [2, 2]], ["K_F", [2, 2]]],
    "inputs": [["pose", "x"], ["param", "a"], ["pose", "y"], ["pose", "z"]],
    "status": STATUS,
    "models": ["flexible", "rigid"],
    "dims": [2, 1],
}


class Fused:
    """The fused pass: freq[i] = x + 10 a + 100 y + 1000 z (each mode) of pose i, read by
    address and stride; status[i] = i % 5; returns rc."""

    def __init__(self, rc=0):
        self.rc = rc
        self.calls = []

    def __call__(self, begin, end, ins, strides, model, ik, mat, jac, freq, vec, status, opts):
        self.calls.append((begin, end, model))
        for i in range(begin, end):
            x, a, y, z = (doubles(ins[k] + 8 * strides[k] * i)[0] for k in range(4))
            if freq is not None:
                dim = 2 - model
                doubles(freq + 8 * dim * i, dim)[:] = x + 10 * a + 100 * y + 1000 * z
            if status is not None:
                np.ctypeslib.as_array((ctypes.c_int8 * 1).from_address(status + i))[0] = i % 5
        return self.rc


def fused_kernels(fn=None, **fused):
    kern = kernels(signature=dict(SIGNATURE, fused=dict(FUSED, **fused)))
    kern._fn["fused"] = fn or Fused()
    return kern


def test_fused_arguments_tables():
    kern = fused_kernels()
    x, z = np.array([1.0, 2.0, 3.0]), np.array([[0.5], [0.25], [0.125]])[:, 0]
    result, n, keep, args = kern.fused_arguments(
        x,
        2.0,
        z,
        {"a": 4.0},
        matrices=("M",),
        ik=("q",),
        jacobians=("J_rows",),
        model="rigid",
        vectors=True,
        status=True,
        normalize=True,
    )
    assert n == 3 and sorted(result) == ["J_rows", "M", "eigentwists", "freq_hz", "q", "status"]
    shapes = {k: v.shape for k, v in result.items()}
    assert shapes == {
        "M": (3, 2, 2),
        "q": (3, 2, 3),
        "J_rows": (3, 2),
        "freq_hz": (3, 1),
        "eigentwists": (3, 1, 1),
        "status": (3,),
    }
    assert result["status"].dtype == np.int8 and result["freq_hz"].dtype == np.float64
    ins, strides, model_id, ik_p, mat_p, jac_p, freq, vec, st_p, opts = args
    assert model_id == 1 and freq == result["freq_hz"].ctypes.data and vec == result["eigentwists"].ctypes.data
    from eigentwist.runtime import eigen, validity

    assert list(opts) == [validity.LEVER_TOL, -1.0, eigen.ROUNDOFF_EPS, 1.0]  # built here, then kept
    assert st_p == result["status"].ctypes.data and opts is kern.fused_options(True)
    assert ik_p[0] == result["q"].ctypes.data and jac_p[0] == result["J_rows"].ctypes.data
    assert mat_p[0] == result["M"].ctypes.data and mat_p[1] is None and len(mat_p) == 2  # K_F not asked
    for i in range(3):  # x, a, y, z of pose i through the tables
        got = [doubles(ins[k] + 8 * strides[k] * i)[0] for k in range(4)]
        assert got == [x[i], 4.0, 2.0, z[i]]


def test_fused_arguments_defaults_and_a_grid_of_poses():
    kern = fused_kernels()
    x = np.zeros((2, 3))
    result, n, _, args = kern.fused_arguments(x, 0.0, 0.0, {"a": 1.0})
    assert n == 6 and sorted(result) == ["K_F", "M"] and result["M"].shape == (2, 3, 2, 2)
    assert args[2] == 0 and args[3] is None and args[5] is None and args[6:9] == (None, None, None)
    result, _, _, args = kern.fused_arguments(x, 0.0, 0.0, {"a": 1.0}, matrices=(), model="flexible", vectors=True)
    assert sorted(result) == ["V", "freq_hz"] and result["V"].shape == (2, 3, 2, 2) and args[4] is None
    assert list(args[9])[3] == 0.0  # not normalized


def test_fused_arguments_refusals():
    kern = fused_kernels()
    p = {"a": 1.0}
    with pytest.raises(InputError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, p, model="stiff")
    assert str(err.value) == "model 'stiff': expected one of ['flexible', 'rigid']"
    with pytest.raises(KeyError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, p, matrices=("M", "K_R"))
    assert err.value.args[0] == "matrices has no output(s) ['K_R']: expected ['M', 'K_F']"
    with pytest.raises(KeyError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, p, ik=("r",))
    assert err.value.args[0] == "inverse_kinematics has no output(s) ['r']: expected ['q']"
    with pytest.raises(KeyError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, p, out={"V": np.zeros((2, 2, 2))})
    assert err.value.args[0] == "out has arrays for ['V'], which this call does not compute"


@pytest.mark.parametrize(
    "arr, got",
    [
        (np.zeros((3, 2)), "(3, 2) float64"),
        (np.zeros((2, 2), dtype=np.float32), "(2, 2) float32"),
        (np.zeros((2, 2), order="F"), None),
        ("read-only", None),
        ([[0.0, 0.0], [0.0, 0.0]], "None list"),
    ],
)
def test_fused_out_arrays_are_checked(arr, got):
    kern = fused_kernels()
    if isinstance(arr, str):
        arr = np.zeros((2, 2))
        arr.flags.writeable = False
    elif isinstance(arr, np.ndarray) and arr.flags.f_contiguous and arr.ndim == 2 and arr.shape == (2, 2):
        arr = np.zeros((2, 4))[:, ::2]  # not C-contiguous
    with pytest.raises(InputError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, {"a": 1.0}, matrices=(), model="flexible", out={"freq_hz": arr})
    head = "out['freq_hz']: expected a writeable C-contiguous float64 array of shape (2, 2), got "
    assert str(err.value).startswith(head) and (got is None or str(err.value) == head + got)
    out = np.zeros((2, 2))
    result, *_ = kern.fused_arguments(
        np.zeros(2), 0.0, 0.0, {"a": 1.0}, matrices=(), model="flexible", out={"freq_hz": out}
    )
    assert result["freq_hz"] is out


def test_rotation_from_the_rotation_vector_or_the_matrix():
    inputs = [["pose", "x"], ["param", "a"], ["pose", "y"], ["pose", "z"], ["param", "R_00"], ["param", "R_01"]]
    kern = fused_kernels(inputs=inputs, rotation=True)
    p = {"a": 1.0, "R_00": 0.5, "R_01": 0.25}
    _, _, _, args = kern.fused_arguments(1.0, 2.0, 3.0, dict(p, rot_x=0.1, rot_y=0.2, rot_z=0.3))
    ins = args[0]
    got = [doubles(ins[k])[0] for k in range(9)]
    assert got == [1.0, 1.0, 2.0, 3.0, 0.0, 0.0, 0.1, 0.2, 0.3]  # R_ij placeholders, the vector after them
    _, _, _, args = kern.fused_arguments(1.0, 2.0, 3.0, p)
    assert [doubles(args[0][k])[0] for k in range(6)] == [1.0, 1.0, 2.0, 3.0, 0.5, 0.25]
    assert args[0][6] is None  # no rotation vector: the pass reads R_ij


@pytest.mark.parametrize("threads", [None, 2])
def test_fused_runs_ranges_of_blocks(threads):
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    fn = Fused()
    kern = fused_kernels(fn)
    n = 2 * MIN_BLOCKS_PER_THREAD * kern.BLOCK
    x = np.arange(n) * 1.0
    more = {} if threads is None else {"threads": threads}
    out = kern.fused(x, 0.5, 0.25, {"a": 2.0}, matrices=(), model="flexible", status=True, **more)
    assert np.array_equal(out["freq_hz"], np.repeat((x + 20.0 + 50.0 + 250.0)[:, None], 2, axis=1))
    assert np.array_equal(out["status"], np.arange(n) % 5)
    assert (len(fn.calls) == 1) is (threads is None) and all(c[0] % kern.BLOCK == 0 for c in fn.calls)
    with pytest.raises(RuntimeError) as err:
        fused_kernels(Fused(rc=9)).fused(x[:2], 0.5, 0.25, {"a": 2.0}, matrices=(), model="flexible")
    assert str(err.value) == "C fused returned 9"


def test_pack_reuses_the_scalars_of_the_same_objects():
    kern = fused_kernels()
    a = 2.0
    kern.fused_arguments(np.zeros(3), 1.0, 0.0, {"a": a})
    packed = kern._packed
    _, n, _, args = kern.fused_arguments(np.ones(4), 1.0, 0.0, {"a": a})
    assert kern._packed is packed and n == 4 and doubles(args[0][0] + 8 * args[1][0] * 3)[0] == 1.0
    _, n, _, args = kern.fused_arguments(np.ones(4), 1.0, 0.0, {"a": 3.0})
    assert kern._packed is not packed and doubles(args[0][1])[0] == 3.0
    _, n, _, _ = kern.fused_arguments(1.0, 1.0, 0.0, {"a": 3.0})  # every input a scalar: one pose
    assert n == 1


def test_fused_frequencies_valid_and_stable_from_the_status(monkeypatch):
    """Status i % 5 of pose i: valid where ok (0) or unstable (4), stable where not unstable;
    with ``check`` the first invalid pose is raised (by raise_invalid, recorded here)."""
    kern = fused_kernels()
    raised, given = [], []

    def record(self, k, x, y, z, p, lead):
        raised.append((k, lead))
        given.append((x, y, z, p))

    monkeypatch.setattr(ck.CKernels, "raise_invalid", record)
    x = np.arange(6) * 1.0
    res = kern.fused_frequencies(x, 0.0, 0.0, {"a": 1.0}, check=False)
    assert sorted(res) == ["freq_hz", "stable", "valid"] and raised == []
    assert res["valid"].tolist() == [True, False, False, False, True, True]
    assert res["stable"].tolist() == [True, True, True, True, False, True]
    assert np.array_equal(res["freq_hz"], np.repeat((x + 10.0)[:, None], 2, axis=1))
    res = kern.fused_frequencies(x, 0.0, 0.0, {"a": 1.0}, model="rigid", vectors=True)
    assert raised == [(1, (6,))] and res["freq_hz"].shape == (6, 1) and res["eigentwists"].shape == (6, 1, 1)
    assert given[0][0] is x and given[0][1:3] == (0.0, 0.0) and given[0][3] == {"a": 1.0}
    raised.clear()
    kern.fused_frequencies(x[[0, 4]], 0.0, 0.0, {"a": 1.0})  # statuses 0 and 1: pose 1
    assert raised == [(1, (2,))]
    raised.clear()
    kern.fused_frequencies(x[:1], 0.0, 0.0, {"a": 1.0, "on_gravity_preload": 0.0})  # a switch off is no preload
    assert raised == []
    with pytest.raises(InputError) as err:
        kern.fused_frequencies(x, 0.0, 0.0, {"a": 1.0, "on_gravity_preload": np.array([0.0, 1.0])})
    assert str(err.value) == "the fused C path has no gravity preload: switch it off or use Evaluator.frequencies"


@pytest.mark.parametrize("rotation", [False, True])
def test_prepare_fused_hands_the_pass_to_a_prepared_call(monkeypatch, rotation):
    from eigentwist.runtime import fused_call

    made = []
    monkeypatch.setattr(fused_call, "FusedCall", lambda *a, **k: made.append((a, k)) or "prepared")
    inputs = FUSED["inputs"] + ([["param", "R_00"]] if rotation else [])
    kern = fused_kernels(inputs=inputs, rotation=rotation)
    p = {"a": 1.0}
    assert kern.prepare_fused(p, {"x": 3, "y": 3, "z": 3}, model="rigid", vectors=True, matrices=("K_F",)) == "prepared"
    (args, kw) = made[0]
    names = ["x", "a", "y", "z"] + (["R_00", "rot_x", "rot_y", "rot_z"] if rotation else [])
    assert args == (("a new function object", "et_toy_fused"), names, p, {"x": 3, "y": 3, "z": 3})
    assert kw["unread"] == ({"rot_x", "rot_y", "rot_z"} if rotation else set())  # no rotation vector among the poses
    assert (kw["model_id"], kw["dim"], kw["vectors"], kw["block"]) == (1, 1, True, 4)
    assert kw["matrices"] == (2, ((1, "K_F", (2, 2)),)) and kw["check"] is ck._check_rc
    assert kw["options"]() is kern.fused_options(True)
    kern.prepare_fused(p, {"x": 3, "rot_x": 6, "rot_y": 6, "rot_z": 6}, model="flexible")
    assert made[1][1]["unread"] == ({"R_00"} if rotation else set()) and made[1][1]["matrices"] == (2, ())
    assert made[1][1]["model_id"] == 0 and made[1][1]["dim"] == 2 and made[1][1]["vectors"] is False
    with pytest.raises(KeyError) as err:
        kern.prepare_fused(p, {}, model="rigid", matrices=("M", "K_R", "G"))
    assert err.value.args[0] == "matrices has no output(s) ['G', 'K_R']: expected ['M', 'K_F']"


def test_prepared_dimension_from_the_eigen_solver_without_dims():
    from eigentwist.runtime import fused_call

    made = []
    fused = {k: v for k, v in FUSED.items() if k != "dims"}
    kern = kernels(signature=dict(SIGNATURE, fused=fused))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fused_call, "FusedCall", lambda *a, **k: made.append(k))
        kern.prepare_fused({"a": 1.0}, {}, model="rigid")
    assert made[0]["dim"] == 3  # the eigen-solver's dims [2, 3], the model's entry
    result, *_ = kern.fused_arguments(0.0, 0.0, 0.0, {"a": 1.0}, matrices=(), model="rigid")
    assert result["freq_hz"].shape == (3,)  # one pose of scalars: no leading axis


def test_fused_frequencies_on_one_thread_unless_asked():
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    fn = Fused()
    kern = fused_kernels(fn)
    x = np.zeros(2 * MIN_BLOCKS_PER_THREAD * kern.BLOCK)
    kern.fused_frequencies(x, 0.0, 0.0, {"a": 1.0}, check=False)
    assert len(fn.calls) == 1
    kern.fused_frequencies(x, 0.0, 0.0, {"a": 1.0}, check=False, threads=2)
    assert len(fn.calls) > 2


def test_generalized_eigh_on_threads_and_integer_matrices():
    """Two threads' worth of pairs: each range's K, M, lam and V at its first pair; integer K and
    M read as doubles; a failing return code names the eigen-solver."""
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    kern = kernels()
    fn = Eigh()
    kern._fn["eigh"] = fn
    N = 2 * MIN_BLOCKS_PER_THREAD * kern.BLOCK
    K = np.stack([np.diag([k + 2, k + 1]) for k in range(N)])
    M = np.broadcast_to(np.eye(2, dtype=int), (N, 2, 2))
    lam, V = kern.generalized_eigh(K, M, threads=2)
    assert len(fn.calls) > 1 and np.array_equal(lam, np.stack([[k + 1.0, k + 2.0] for k in range(N)]))
    assert np.array_equal(V, np.broadcast_to(np.eye(2), (N, 2, 2)))
    lam, _ = kern.generalized_eigh(K, M)
    assert fn.calls[-1][0] == N  # one call unless asked
    kern._fn["eigh"] = lambda *a: 6
    with pytest.raises(RuntimeError) as err:
        kern.generalized_eigh(K, M)
    assert str(err.value) == "C eigh returned 6"


# ------------------------------------------------------------ raise_invalid
class Kernel:
    """A stand-in kernel of ``count`` inputs: ``f`` maps the (n, count) values read by
    address and stride to the outputs' (n, ...) arrays, written in the output order."""

    def __init__(self, count, f):
        self.count, self.f, self.calls = count, f, []

    def __call__(self, n, addresses, strides, outs):
        values = np.array(
            [[doubles(addresses[k] + 8 * strides[k] * i)[0] for k in range(self.count)] for i in range(n)]
        )
        self.calls.append(values)
        for o, arr in enumerate(self.f(values)):
            arr = np.ascontiguousarray(arr, dtype=np.float64).reshape(-1)
            doubles(outs[o], arr.size)[:] = arr
        return 0


def toy_ik(v):
    """Leg A at q = (x, y, z), leg B at (x + 1, y, z) (y NaN below -1); sin_q3 = (x, y) / r,
    cos_q2 = (z, z) / r."""
    r, x, y, z = v.T
    q = np.stack([np.stack([x, y, z], -1), np.stack([x + 1, np.where(y < -1, np.nan, y), z], -1)], 1)
    return q, np.stack([x / r, y / r], -1), np.stack([z / r, z / r], -1)


def toy_jacobians(v):
    """lever = g (q_A0, q_B0): g x and g (x + 1); J_rows zero."""
    g, qa, qb = v.T
    return np.zeros((len(g), 2)), np.stack([g * qa, g * qb], -1)


def pose_kernels(lever=True):
    outputs = [["J_rows", [2]]] + ([["lever", [2]]] if lever else [])
    sig = dict(
        SIGNATURE,
        kernels={
            "inverse_kinematics": {
                "function": "et_toy_ik",
                "inputs": [["param", "r", None], ["pose", "x", None], ["pose", "y", None], ["pose", "z", None]],
                "outputs": [["q", [2, 3]], ["sin_q3", [2]], ["cos_q2", [2]]],
            },
            "jacobians": {
                "function": "et_toy_jac",
                "inputs": [["param", "g", None], ["q", "q_0_0", [0, 0]], ["q", "q_1_0", [1, 0]]],
                "outputs": outputs,
            },
        },
    )
    lib = types.SimpleNamespace(
        et_toy_ik=Kernel(4, toy_ik),
        et_toy_jac=Kernel(3, toy_jacobians if lever else lambda v: toy_jacobians(v)[:1]),
        et_toy_fused=types.SimpleNamespace(),
        et_toy_eigh=types.SimpleNamespace(),
    )
    return ck.CKernels(lib, sig, ck.Build("lib.so", "portable", []))


LEGS = [types.SimpleNamespace(name="leg A"), types.SimpleNamespace(name="leg B")]


def test_the_jacobians_kernel_reads_its_parameters_and_joint_coordinates():
    kern = pose_kernels()
    q = np.array([[[0.5, 9.0, 9.0], [1.5, 9.0, 9.0]], [[2.0, 9.0, 9.0], [3.0, 9.0, 9.0]]])
    out = kern.jacobians(q, {"g": np.array([2.0, 4.0]), "r": 1.0})
    assert np.array_equal(out["lever"], [[1.0, 3.0], [8.0, 12.0]]) and out["J_rows"].shape == (2, 2)
    assert len(kern._lib.et_toy_jac.calls) == 1 and kern._lib.et_toy_ik.calls == []


def test_an_unreachable_pose_names_its_leg_and_check():
    """Pose 3 of a (2, 2) batch (x broadcast down, y across): (0.5, 2, 0) m, where leg B's
    sin_q3 = y / r = 2 lies outside [-1, 1]; only that pose is recomputed."""
    kern = pose_kernels()
    x, y, p = np.array([[0.1], [0.5]]), np.array([0.0, 2.0]), {"r": np.array([[1.0], [1.0]]), "g": 1.0}
    with pytest.raises(UnreachablePoseError) as err:
        kern.raise_invalid(3, x, y, 0.0, p, (2, 2), legs=LEGS)
    assert str(err.value) == (
        "pose [0.5, 2.0, 0.0] m is unreachable for leg B: the parallelogram cannot tilt that far "
        "(sin_q3 = 2, expected within [-1, 1])"
    )
    (values,) = kern._lib.et_toy_ik.calls  # r, x, y, z of the one pose
    assert values.tolist() == [[1.0, 0.5, 2.0, 0.0]] and kern._lib.et_toy_jac.calls == []
    with pytest.raises(UnreachablePoseError) as err:  # cos_q2 = z / r of both legs
        kern.raise_invalid(0, x, y, np.array([[-3.0], [0.0]]), p, (2, 2), legs=LEGS)
    assert str(err.value).startswith("pose [0.1, 0.0, -3.0] m is unreachable for leg A: the lower link")


def test_a_pose_without_joint_coordinates_is_unreachable():
    """Leg B's checks pass at y = -1.5, r = 2 (sin_q3 = -0.75) but its IK gives NaN: the pose is
    unreachable, as the evaluator says, not singular (leg A's lever g x = 0 vanishes too)."""
    with pytest.raises(UnreachablePoseError) as err:
        pose_kernels().raise_invalid(0, 0.0, -1.5, 0.0, {"r": 2.0, "g": 1.0}, (), legs=LEGS)
    assert str(err.value) == (
        "pose [0.0, -1.5, 0.0] m is unreachable for leg B: its inverse kinematics gives no finite joint "
        "coordinates (expected a pose the leg can span)"
    )


def test_a_reachable_pose_with_a_vanishing_lever_is_singular():
    """lever = g x for leg A: 0.25 x 0.002 = 0.0005, at or below LEVER_TOL = 0.001 alone or
    divided by l1 = 0.5 (the ratio 0.001 is not above it), above it divided by l1 = 0.25."""
    kern = pose_kernels()
    x = np.array([0.3, 0.002])
    with pytest.raises(SingularPoseError) as err:
        kern.raise_invalid(1, x, 0.0, 0.0, {"r": 1.0, "g": 0.25}, (2,), legs=LEGS)
    assert str(err.value) == (
        "pose [0.002, 0.0, 0.0] m is serial singular for leg A: actuation lever w_a.t_a "
        "(the leg's unit twists are dependent) = 0.0005 (expected |.| > 0.001)"
    )
    (values,) = kern._lib.et_toy_jac.calls  # g and leg A's, leg B's first joint coordinates
    assert values.tolist() == [[0.25, 0.002, 1.002]]
    with pytest.raises(SingularPoseError) as err:
        kern.raise_invalid(1, x, 0.0, 0.0, {"r": 1.0, "g": 0.25, "l1": np.array([1.0, 0.5])}, (2,), legs=LEGS)
    assert "for leg A: actuation lever w_a1.t_a1/l1 = 0.001 (expected |.| > 0.001)" in str(err.value)
    with pytest.raises(UnreachablePoseError) as err:
        kern.raise_invalid(1, x, 0.0, 0.0, {"r": 1.0, "g": 0.25, "l1": np.array([1.0, 0.25])}, (2,), legs=LEGS)
    assert str(err.value) == (
        "pose [0.002, 0.0, 0.0] m gives non-finite frequencies (the inertia matrix is not positive definite there)"
    )


def test_a_pose_neither_unreachable_nor_singular_has_non_finite_frequencies():
    """Integer coordinates are named as the floats they are read as; a robot without a lever
    output is not checked for one (leg A's lever 0 would be singular)."""
    with pytest.raises(UnreachablePoseError) as err:
        pose_kernels().raise_invalid(0, np.array([1]), 0, 0, {"r": 2, "g": 1}, (1,), legs=LEGS)
    assert str(err.value).startswith("pose [1.0, 0.0, 0.0] m gives non-finite frequencies (")
    with pytest.raises(UnreachablePoseError) as err:
        pose_kernels(lever=False).raise_invalid(0, 0.0, 0.0, 0.0, {"r": 1.0, "g": 1.0}, (), legs=LEGS)
    assert str(err.value).startswith("pose [0.0, 0.0, 0.0] m gives non-finite frequencies (")


def test_a_shipped_robots_legs_by_default(monkeypatch):
    import eigentwist.robots as robots

    asked = []
    monkeypatch.setattr(robots, "get", lambda name: asked.append(name) or types.SimpleNamespace(legs=LEGS))
    with pytest.raises(UnreachablePoseError) as err:
        pose_kernels().raise_invalid(0, 0.5, 2.0, 0.0, {"r": 1.0, "g": 1.0}, ())
    assert asked == ["toy"] and "unreachable for leg B:" in str(err.value)


def test_a_six_dof_pose_is_named_with_its_rotation_vector():
    """R_ij of a quarter turn about z: rotation vector (0, 0, pi/2) rad; the IK gets x, y, z."""
    R = {"R_00": 0.0, "R_01": -1.0, "R_02": 0.0, "R_10": 1.0, "R_11": 0.0, "R_12": 0.0, "R_20": 0.0, "R_21": 0.0}
    p = dict(R, R_22=1.0, r=1.0, g=1.0)
    kern = pose_kernels()
    with pytest.raises(UnreachablePoseError) as err:
        kern.raise_invalid(1, np.array([0.0, 0.5]), 2.0, 0.0, p, (2,), legs=LEGS)
    assert str(err.value).startswith(f"pose [0.5, 2.0, 0.0, 0.0, 0.0, {np.pi / 2!r}] (m, rad) is unreachable for leg B")
    assert kern._lib.et_toy_ik.calls[0].tolist() == [[1.0, 0.5, 2.0, 0.0]]


# ------------------------------------------------------- building and loading
def test_address_is_the_functions_entry_point():
    """The address, turned back into a C function, calls the same function."""
    kern = kernels()
    proto = ctypes.CFUNCTYPE(ctypes.c_int)
    kern._fn["matrices"] = proto(lambda: 42)
    assert proto(kern.address("matrices"))() == 42


def stand_in_library(robot_prefix, abi, signature):
    """A library whose ``<prefix>_abi_version`` and ``<prefix>_signature`` are C functions
    (ctypes callbacks) returning ``abi`` and the address of the signature's JSON text."""
    text = ctypes.create_string_buffer(json.dumps(signature).encode())
    return types.SimpleNamespace(
        **{
            f"{robot_prefix}_abi_version": ctypes.CFUNCTYPE(ctypes.c_int)(lambda: abi),
            f"{robot_prefix}_signature": ctypes.CFUNCTYPE(ctypes.c_void_p)(lambda: ctypes.addressof(text)),
            "text": text,
        }
    )


def test_load_reads_the_abi_and_the_signature(monkeypatch, tmp_path):
    """The robot's functions are ``et_<name>`` with every character that is not a letter or
    digit replaced by ``_``; the signature is a ``const char *`` (NUL-terminated JSON)."""
    opened = []
    lib = stand_in_library("et_my_robot_2", ck.ABI_VERSION, {"robot": "my-robot.2", "block": 4})
    monkeypatch.setattr(ctypes, "CDLL", lambda name: opened.append(name) or lib)
    got, sig = ck._load(tmp_path / "lib.so", "my-robot.2")
    assert got is lib and sig == {"robot": "my-robot.2", "block": 4} and opened == [str(tmp_path / "lib.so")]
    old = stand_in_library("et_toy", ck.ABI_VERSION - 1, {})
    monkeypatch.setattr(ctypes, "CDLL", lambda name: old)
    with pytest.raises(OSError) as err:
        ck._load(tmp_path / "old.so", "toy")
    assert str(err.value) == (
        f"{tmp_path / 'old.so'}: ABI version {ck.ABI_VERSION - 1} (expected {ck.ABI_VERSION}): "
        "regenerate with `eigentwist generate`"
    )


def test_the_generated_sources_abi_is_the_loaders():
    source = heli4_source()
    assert re.search(r"int et_heli4_abi_version\(void\)\s*\{\s*return (\d+);", source).group(1) == str(ck.ABI_VERSION)
    assert re.search(r"const char \*et_heli4_signature\(void\)", source)


class Builder:
    """A stand-in of build_library (same parameters): the flag sets in ``fail`` raise."""

    def __init__(self, tmp_path, fail):
        self.tmp_path, self.fail, self.calls = tmp_path, fail, []

    def __call__(self, source, name, cc, flags, directory=None):
        self.calls.append((source, name, cc, flags, directory))
        if flags[0] in self.fail:
            raise self.fail[flags[0]]
        return self.tmp_path / f"{name}{flags[0]}.so"


def test_compile_and_load_falls_through_to_the_next_flag_set(monkeypatch, tmp_path):
    loaded = []
    build = Builder(tmp_path, {"-fast": subprocess.CalledProcessError(1, ["/opt/cc", "-fast"], stderr="bad flag")})
    monkeypatch.setattr(ck, "find_compiler", lambda: "/opt/cc")
    monkeypatch.setattr(ck, "flag_sets", lambda: [("fast", ["-fast"]), ("plain", ["-O0", "-shared"])])
    monkeypatch.setattr(ck, "build_library", build)
    monkeypatch.setattr(ck, "_load", lambda path, robot: loaded.append((path, robot)) or ("lib", {"robot": robot}))
    lib, sig, built = ck.compile_and_load("toy", source="int x;", directory=tmp_path / "cache")
    assert build.calls == [
        ("int x;", "toy_c", "/opt/cc", ["-fast"], tmp_path / "cache"),
        ("int x;", "toy_c", "/opt/cc", ["-O0", "-shared"], tmp_path / "cache"),
    ]
    assert loaded == [(tmp_path / "toy_c-O0.so", "toy")] and (lib, sig) == ("lib", {"robot": "toy"})
    assert built == ck.Build(tmp_path / "toy_c-O0.so", "plain", ["-O0", "-shared"])


def test_compile_and_load_reports_every_flag_sets_failure(monkeypatch, tmp_path):
    """The compiler's command and the last 2000 characters of its output (none: nothing),
    a library that does not load, a build that raises OSError, then the next flag set."""
    long = "A" + "b" * 2000 + "\n"
    build = Builder(
        tmp_path,
        {
            "-a": subprocess.CalledProcessError(1, ["/opt/cc", "-a", "x.c"], stderr=long),
            "-b": subprocess.CalledProcessError(1, ["/opt/cc", "-b", "x.c"]),
            "-d": PermissionError("cache is read-only"),
        },
    )
    monkeypatch.setattr(ck, "find_compiler", lambda: "/opt/cc")
    monkeypatch.setattr(ck, "flag_sets", lambda: [(n, ["-" + n]) for n in "abcde"])
    monkeypatch.setattr(ck, "build_library", build)

    def load(path, robot):
        raise OSError("undefined symbol: _ZGVdN4v_sin")

    monkeypatch.setattr(ck, "_load", load)
    with pytest.raises(ck.CompileError) as err:
        ck.compile_and_load("toy", source="int x;")
    assert str(err.value) == (
        "could not build the C backend of 'toy' with /opt/cc:\n"
        f"[a] /opt/cc -a x.c\n{'b' * 2000}\n"
        "[b] /opt/cc -b x.c\n\n"
        f"[c] loading {tmp_path / 'toy_c-c.so'} failed: undefined symbol: _ZGVdN4v_sin\n"
        "[d] building failed: cache is read-only\n"
        f"[e] loading {tmp_path / 'toy_c-e.so'} failed: undefined symbol: _ZGVdN4v_sin"
    )
    assert [c[3] for c in build.calls] == [["-a"], ["-b"], ["-c"], ["-d"], ["-e"]] and build.calls[0][4] is None


def test_compile_and_load_reads_the_checked_in_source(monkeypatch, tmp_path):
    """Without ``source``: ``<robot>_c.c`` beside the generated modules, checked against its
    recorded SHA-256 and decoded as UTF-8; a missing one says to generate it."""
    import hashlib

    build = Builder(tmp_path, {})
    monkeypatch.setattr(ck, "GENERATED", tmp_path)
    monkeypatch.setattr(ck, "find_compiler", lambda: "/opt/cc")
    monkeypatch.setattr(ck, "flag_sets", lambda: [("plain", ["-O0"])])
    monkeypatch.setattr(ck, "build_library", build)
    monkeypatch.setattr(ck, "_load", lambda path, robot: ("lib", {}))
    with pytest.raises(FileNotFoundError) as err:
        ck.compile_and_load("toy")
    assert str(err.value) == f"{tmp_path / 'toy_c.c'} does not exist: run `eigentwist generate`" and not build.calls
    text = "/* \u00e9l\u00e9ment */ int x;\n"
    (tmp_path / "toy_c.c").write_bytes(text.encode("utf-8"))
    (tmp_path / "toy.sha256").write_text(f"{hashlib.sha256(text.encode('utf-8')).hexdigest()}  toy_c.c\n")
    ck.compile_and_load("toy")
    assert build.calls == [(text, "toy_c", "/opt/cc", ["-O0"], None)]


def test_load_c_kernels_checks_the_numpy_modules_outputs(monkeypatch):
    """The NumPy module's OUTPUTS (lists, as generated) must be the library's, but for the
    followers kernel, which only NumPy has; a module without OUTPUTS is not compared."""
    asked, build = [], ck.Build("lib.so", "plain", [])
    lib = Library(Matrices())
    monkeypatch.setattr(ck, "compile_and_load", lambda *a, **k: asked.append((a, k)) or (lib, SIGNATURE, build))
    outputs = {k: {o: list(s) for o, s in v["outputs"]} for k, v in SIGNATURE["kernels"].items()}
    same = types.SimpleNamespace(OUTPUTS=dict(outputs, followers={"q_f": [2]}))
    kern = ck.load_c_kernels("toy", same, source="int x;")
    assert asked == [(("toy", "int x;"), {})] and kern._lib is lib and kern.signature is SIGNATURE
    assert kern.build is build and isinstance(kern, ck.CKernels)
    assert ck.load_c_kernels("toy").ROBOT == "toy" and asked[1] == (("toy", None), {})
    ck.load_c_kernels("toy", types.SimpleNamespace())  # no OUTPUTS
    ck.load_c_kernels("toy", types.SimpleNamespace(OUTPUTS={"followers": {"q_f": [2]}}))  # nothing to compare
    other = types.SimpleNamespace(OUTPUTS=dict(outputs, matrices={"M": [2, 2], "s": [1]}))
    with pytest.raises(RuntimeError) as err:
        ck.load_c_kernels("toy", other)
    assert str(err.value) == (
        "the C library of 'toy' and the NumPy module disagree on their outputs: run `eigentwist generate`"
    )


# ------------------------------------------------------------ the arguments' lifetime and shapes
def fill_freed_blocks(*sizes):
    """Arrays of these sizes filled with -7: NumPy hands freed blocks of a size to the next
    arrays of that size, so an address into a freed block then reads -7."""
    return [np.full(size, -7.0) for size in sizes for _ in range(20)]


def test_the_inputs_stay_while_keep_holds_them():
    """The packed scalars and an input converted to doubles (a list) live as long as ``keep``."""
    keep = []
    addresses, strides = ck._inputs([2.0, 3.0, [1.0, 2.0, 4.0]], (3,), keep)
    junk = fill_freed_blocks(3)
    assert strides == [0, 0, 1] and [doubles(addresses[k])[0] for k in range(2)] == [2.0, 3.0]
    assert doubles(addresses[2], 3).tolist() == [1.0, 2.0, 4.0] and len(junk) == 20


def test_the_fused_arguments_stay_while_keep_holds_them():
    kern = fused_kernels()
    result, n, keep, args = kern.fused_arguments([1.0, 2.0, 4.0], [0.5, 0.25, 0.125], 0.0, {"a": 3.0})
    junk = fill_freed_blocks(3, 4)
    ins, strides = args[0], args[1]
    got = [[doubles(ins[k] + 8 * strides[k] * i)[0] for k in range(4)] for i in range(3)]
    assert got == [[1.0, 3.0, 0.5, 0.0], [2.0, 3.0, 0.25, 0.0], [4.0, 3.0, 0.125, 0.0]] and len(junk) == 40


def test_fused_on_no_pose():
    out = fused_kernels().fused(np.zeros(0), 0.0, 0.0, {"a": 1.0}, matrices=(), model="flexible", status=True)
    assert out["freq_hz"].shape == (0, 2) and out["status"].shape == (0,)


@pytest.mark.parametrize("y", [np.array(0.5), np.array([0.5])])
def test_the_poses_are_the_broadcast_of_every_per_pose_input(y):
    """x per pose (3,) and y a writeable array of one value (not packed): three poses."""
    kern = fused_kernels()
    result, n, _, args = kern.fused_arguments(np.arange(3.0), y, 0.0, {"a": 1.0}, matrices=(), model="rigid")
    assert n == 3 and result["freq_hz"].shape == (3, 1)
    assert doubles(args[0][2] + 8 * args[1][2] * 2)[0] == 0.5 and doubles(args[0][0] + 8 * args[1][0] * 2)[0] == 2.0


def test_fused_arguments_tables_sizes_and_options():
    """One table entry per C input (the rotation vector's three after the names); no
    eigentwists unless asked; the option array made once; an out array of the status int8."""
    kern = fused_kernels()
    result, _, _, args = kern.fused_arguments(0.0, 0.0, 0.0, {"a": 1.0}, matrices=(), model="flexible")
    assert sorted(result) == ["freq_hz"] and args[7] is None and len(args[0]) == len(args[1]) == 4
    assert kern.fused_arguments(0.0, 0.0, 0.0, {"a": 1.0}, matrices=())[3][9] is args[9]
    rot = fused_kernels(inputs=FUSED["inputs"] + [["param", "R_00"]], rotation=True)
    _, _, _, args = rot.fused_arguments(0.0, 0.0, 0.0, {"a": 1.0, "R_00": 1.0}, matrices=())
    assert len(args[0]) == len(args[1]) == 5 + 3
    with pytest.raises(InputError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, {"a": 1.0}, matrices=(), status=True, out={"status": np.zeros(2)})
    assert str(err.value) == (
        "out['status']: expected a writeable C-contiguous int8 array of shape (2,), got (2,) float64"
    )
    with pytest.raises(KeyError) as err:
        kern.fused_arguments(np.zeros(2), 0.0, 0.0, {"a": 1.0}, jacobians=("J_rows", "lever"))
    assert err.value.args[0] == "jacobians has no output(s) ['lever']: expected ['J_rows']"


def test_fused_frequencies_asks_no_matrix():
    kern = fused_kernels()
    seen = []
    fn = kern._fn["fused"]
    kern._fn["fused"] = lambda *a: seen.append(a[6]) or fn(*a)  # the matrices' pointers
    kern.fused_frequencies(np.zeros(2), 0.0, 0.0, {"a": 1.0}, check=False)
    assert seen == [None]


def test_follow_hands_the_followers_kernel_and_its_inputs_to_the_driver(monkeypatch):
    """The followers kernel's inputs: x, y, z and R_ij named by their roles (the driver fills
    them from the pose it iterates), the others read at their addresses (pose 2's values)."""
    from eigentwist.runtime import c_levenberg_marquardt as clm

    follow_spec = {
        "function": "et_toy_followers",
        "inputs": [["pose", "y", None], ["param", "a", None], ["param", "R_12", None], ["pose", "x", None]]
        + [["param", "b", None], ["param", "R_00", None], ["pose", "z", None], ["param", "R_21", None]],
        "outputs": [["closure", [2, 3]], ["closure_rate", [2, 3, 6]]],
    }
    sig = dict(SIGNATURE, kernels=dict(SIGNATURE["kernels"], followers=follow_spec))
    lib = Library(Matrices())
    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ck._PTRS, ck._I64P, ck._PTRS)
    lib.et_toy_followers = proto(lambda *a: 0)
    kern = ck.CKernels(lib, sig, ck.Build("lib.so", "portable", []))
    seen, blocks = [], []

    def follow(address, block, roles, addresses, strides, followers, full, q, rows, iterations, tol, threads):
        values = [doubles(a + 8 * s * 2)[0] if r < 0 else None for a, s, r in zip(addresses, strides, roles)]
        seen.append((address, roles, strides, followers, full, q, rows, iterations, tol, threads, values))
        blocks.append(block)
        assert all(a == 0 for a, r in zip(addresses, roles) if r >= 0)  # filled by the driver: no address
        return "the driver's result"

    monkeypatch.setattr(clm, "followers_driver", lambda: object())
    monkeypatch.setattr(clm, "follow", follow)
    full = np.arange(18.0).reshape(3, 6)
    q = np.zeros((3, 1, 3), dtype=int)
    p = {"a": np.array([1.0, 2.0, 4.0]), "b": 7.0, "_full": full}
    assert kern.follow(q, p, (0, 1, 5), 40, 1e-12, threads=2) == "the driver's result"
    address, roles, strides, followers, full_given, q_given, rows, its, tol, threads, values = seen[0]
    assert address == ctypes.cast(lib.et_toy_followers, ctypes.c_void_p).value
    assert roles == [1, -1, 3 + 5, 0, -1, 3, 2, 3 + 7] and followers == [0, 1, 5]
    assert strides == [0, 1, 0, 0, 0, 0, 0, 0] and rows == 6  # closure (2, 3): six rows
    assert values == [None, 4.0, None, None, 7.0, None, None, None]
    assert full_given is full and q_given.dtype == np.float64 and q_given.shape == (3, 1, 3)
    assert (its, tol, threads) == (40, 1e-12, 2)
    kern.follow(q, {**p, "a": 1.0}, [2], 40, 1e-12)
    assert seen[1][9] == 1 and seen[1][2] == [0] * 8 and seen[1][3] == [2]
    only_pose = dict(follow_spec, inputs=[["pose", "x", None], ["param", "R_22", None]])  # nothing read by address
    kern = ck.CKernels(lib, dict(sig, kernels=dict(sig["kernels"], followers=only_pose)), kern.build)
    kern.follow(q, p, [0], 40, 1e-12)
    assert seen[2][1] == [0, 3 + 8] and seen[2][2] == [0, 0] and seen[2][10] == [None, None]
    assert blocks == [None, None, None]  # the signature names no block function
    lib.et_toy_followers_block_entry = proto(lambda *a: 0)
    block = ctypes.cast(lib.et_toy_followers_block_entry, ctypes.c_void_p).value
    for outputs, want in (
        ([["closure", [2, 3]], ["closure_rate", [2, 3, 6]]], block),  # rows of the driver's layout
        ([["closure", [2, 3]], ["closure_rate", [2, 6, 3]]], None),  # the rates in another layout
    ):
        spec = dict(follow_spec, outputs=outputs, block="et_toy_followers_block_entry")
        ck.CKernels(lib, dict(sig, kernels=dict(sig["kernels"], followers=spec)), kern.build).follow(q, p, [0], 4, 1e-9)
        assert blocks[-1] == want
    monkeypatch.setattr(clm, "followers_driver", lambda: None)  # no C driver: NumPy's
    assert kern.follow(q, p, (0, 1, 5), 40, 1e-12) is None
