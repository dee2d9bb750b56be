"""The Python side of the compiled damped-modes driver (:mod:`eigentwist.runtime.c_damped`) on
stand-ins of its C entries written here: each stand-in takes its arguments by the parameter names
of the C declaration in ``SOURCE`` and, where it writes results, reads each pose's inputs at the
addresses it is given (pose i of an input at ``address + i * bytes per pose``), so each pose's
results say which values reached it. The declared argument types are checked against the C
declarations. No compile.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

from eigentwist.runtime import c_damped as cd
from eigentwist.runtime import ccompile
from eigentwist.runtime.damped import RIGID, actuator_wrenches
from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

from .c_signatures import Recorder, check

ENTRIES = {
    "et_damped": None,
    "et_wrenches": ("_WRENCHES", 0),
    "et_wrenches_complex": ("_WRENCHES", 1),
    "et_damped_pass": ("_PASS", 0),
    "et_damped_legs": ("_LEGS", 0),
    "et_exact_pass": ("_EXACT", 0),
    "et_damped_complex": ("_COMPLEX", 0),
}


def doubles(address, count, dtype=ctypes.c_double):
    return np.ctypeslib.as_array((dtype * count).from_address(address))


class Library:
    def __init__(self):
        for name in ENTRIES:
            setattr(self, name, type("CFunction", (), {})())


@pytest.fixture
def fresh(monkeypatch):
    for name in ("_DRIVER", "_LIBRARIES", "_WRENCHES", "_PASS", "_LEGS", "_EXACT", "_COMPLEX"):
        monkeypatch.setattr(cd, name, [])


def test_driver_declares_every_entrys_c_signature_once(fresh, monkeypatch):
    built = []
    monkeypatch.setattr(ccompile, "load_library", lambda source, name: built.append((source, name)) or Library())
    fn = cd.driver()
    lib = cd._LIBRARIES[0]
    assert fn is lib.et_damped and cd.driver() is fn and built == [(cd.SOURCE, "damped")]
    for name, slot in ENTRIES.items():
        entry = getattr(lib, name)
        check(cd.SOURCE, name, entry.argtypes, entry.restype)
        if slot is not None:
            assert getattr(cd, slot[0])[slot[1]] is entry, name
    assert len(cd._WRENCHES) == 2 and all(len(getattr(cd, s)) == 1 for s in ("_PASS", "_LEGS", "_EXACT", "_COMPLEX"))


def test_no_driver_without_a_compiler(fresh, monkeypatch):
    tries = []
    monkeypatch.setattr(ccompile, "load_library", lambda *a: tries.append(a))
    assert cd.driver() is None and cd.driver() is None and len(tries) == 1 and cd._LIBRARIES == []
    assert cd.wrenches(np.ones((1, 1, 1, 6)), np.ones((1, 1, 1, 1)), RIGID) is None


def test_the_sizes_are_the_sources():
    assert (cd.MAX_MODES, cd.MAX_LEGS) == (12, 16)
    assert f"#define MAXN {cd.MAX_MODES}\n" in cd.SOURCE and f"#define MAXL {cd.MAX_LEGS}\n" in cd.SOURCE


def poles_effect(call, inputs, n, L, complex_h=False):
    """Write, per pose i of the range: wn = sum(M) + 10 sum(K); zeta = sum(W) + 100 sum(h);
    wd = sum(kd) + 2 sum(cd) + 3 sum(td); poles = i + i (eliminate + unstable + ambiguous);
    stable = i odd; status = i % 3 == 0 (i: the range's own index)."""
    count, n, L = call["count"], call["n"], call["L"]
    sizes = {"M": n * n, "K": n * n, "Kl": n * n, "W": L * n, "h": L, "kd": L, "cd": L, "td": L}
    for i in range(count):
        v = {}
        for name in inputs:
            if call[name] is None:
                v[name] = 0.0
                continue
            cplx = complex_h and name in ("W", "h")
            raw = doubles(call[name] + (16 if cplx else 8) * sizes[name] * i, sizes[name] * (2 if cplx else 1))
            v[name] = raw.sum()
        doubles(call["wn"] + 8 * n * i, n)[:] = v["M"] + 10 * v["K"] + 1000 * v.get("Kl", 0.0)
        doubles(call["zeta"] + 8 * n * i, n)[:] = v["W"] + 100 * v["h"]
        doubles(call["wd"] + 8 * n * i, n)[:] = v["kd"] + 2 * v["cd"] + 3 * v["td"]
        p = doubles(call["poles"] + 16 * n * i, 2 * n)
        p[0::2], p[1::2] = i, call["eliminate"] + call["unstable"] + call["ambiguous"]
        doubles(call["stable"] + i, 1, ctypes.c_int8)[0] = i % 2
        doubles(call["status"] + i, 1, ctypes.c_int8)[0] = i % 3 == 0


def poses_inputs(N, n=2, L=3):
    rng = np.random.default_rng(4)
    return [rng.normal(size=s) for s in ((N, n, n), (N, n, n), (N, L, n), (N, L), (N, L), (N, L), (N, L))]


@pytest.mark.parametrize("threads", [1, 2])
def test_solve_reads_each_poses_inputs(monkeypatch, threads):
    N = 2 * MIN_BLOCKS_PER_THREAD * cd.BLOCK if threads == 2 else 5
    n, L = 2, 3
    fn = Recorder(
        cd.SOURCE, "et_damped", effect=lambda c: poles_effect(c, ("M", "K", "W", "h", "kd", "cd", "td"), n, L)
    )
    monkeypatch.setattr(cd, "driver", lambda: fn)
    M, K, W, h, kd, c_d, td = poses_inputs(N, n, L)
    wn, zeta, wd, poles, stable, redo = cd.solve(M, K, W, h, kd, c_d, td, 1.0, 2.0, 4.0, threads=threads)
    assert len(fn.calls) == (1 if threads == 1 else len(fn.calls)) and (threads == 1) == (len(fn.calls) == 1)
    assert all((c["n"], c["L"]) == (n, L) for c in fn.calls) and sum(c["count"] for c in fn.calls) == N
    assert np.array_equal(wn, np.repeat((M.sum(axis=(1, 2)) + 10 * K.sum(axis=(1, 2)))[:, None], n, axis=1))
    assert np.allclose(zeta, (W.sum(axis=(1, 2)) + 100 * h.sum(axis=1))[:, None], rtol=1e-14)
    assert np.allclose(wd, (kd.sum(axis=1) + 2 * c_d.sum(axis=1) + 3 * td.sum(axis=1))[:, None], rtol=1e-14)
    first = np.concatenate([np.arange(c["count"]) for c in fn.calls])  # each range's own index
    assert np.array_equal(poles, np.repeat((first + 7j)[:, None], n, axis=1))
    assert stable.dtype == bool and np.array_equal(stable, first % 2 == 1)
    assert redo.dtype == bool and np.array_equal(redo, first % 3 == 0)


@pytest.mark.parametrize("threads", [None, 2])
def test_solve_complex_reads_the_complex_wrenches_and_a_missing_k_loss(monkeypatch, threads):
    """Two threads' worth of poses (each range's inputs at its first pose) or one call by
    default; integer M, K and K_loss read as doubles."""
    n, L, N = 2, 3, 2 * MIN_BLOCKS_PER_THREAD * cd.BLOCK
    inputs = ("M", "K", "Kl", "W", "h", "kd", "cd", "td")
    fn = Recorder(cd.SOURCE, "et_damped_complex", effect=lambda c: poles_effect(c, inputs, n, L, complex_h=True))
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_COMPLEX", [fn])
    M, K, W, h, kd, c_d, td = poses_inputs(N, n, L)
    M, K = np.round(M * 10).astype(int), np.round(K * 10).astype(int)
    Kl = np.full((N, n, n), 2, dtype=int)
    Wc, hc = W * (1 + 2j), h * (1 - 1j)
    more = {} if threads is None else {"threads": threads}
    wn, zeta, wd, _, _, _ = cd.solve_complex(M, K, Kl, Wc, hc, kd, c_d, td, 1.0, 2.0, 4.0, **more)
    assert (len(fn.calls) == 1) is (threads is None) and all((c["n"], c["L"]) == (n, L) for c in fn.calls)
    assert np.allclose(wn, (M.sum(axis=(1, 2)) + 10 * K.sum(axis=(1, 2)) + 1000 * 8.0)[:, None], rtol=1e-14)
    assert np.allclose(zeta, (3 * W.sum(axis=(1, 2)) + 100 * 0 * h.sum(axis=1))[:, None], rtol=1e-12)
    assert np.allclose(wd, (kd.sum(axis=1) + 2 * c_d.sum(axis=1) + 3 * td.sum(axis=1))[:, None], rtol=1e-14)
    Wi = np.round(10 * W).astype(int)  # real integer wrenches: read as complex doubles
    wn, zeta, *_ = cd.solve_complex(M, K, None, Wi, hc, kd, c_d, td, 1.0, 2.0, 4.0)
    assert fn.calls[-1]["Kl"] is None
    assert np.allclose(zeta, (Wi.sum(axis=(1, 2)) + 100 * 0 * h.sum(axis=1))[:, None], rtol=1e-12)
    assert np.allclose(wn, (M.sum(axis=(1, 2)) + 10 * K.sum(axis=(1, 2)))[:, None], rtol=1e-14)


def test_solve_reads_integer_inputs_as_doubles_on_one_thread_by_default(monkeypatch):
    n, L, N = 2, 3, 2 * MIN_BLOCKS_PER_THREAD * cd.BLOCK
    fn = Recorder(
        cd.SOURCE, "et_damped", effect=lambda c: poles_effect(c, ("M", "K", "W", "h", "kd", "cd", "td"), n, L)
    )
    monkeypatch.setattr(cd, "driver", lambda: fn)
    M, K, W, h, kd, c_d, td = (np.round(10 * v).astype(int) for v in poses_inputs(N, n, L))
    wn, zeta, wd, *_ = cd.solve(M, K, W, h, kd, c_d, td, 1.0, 2.0, 4.0)
    assert len(fn.calls) == 1
    assert np.array_equal(wn[:, 0], M.sum(axis=(1, 2)) + 10 * K.sum(axis=(1, 2)))
    assert np.array_equal(zeta[:, 0], W.sum(axis=(1, 2)) + 100 * h.sum(axis=1))
    assert np.array_equal(wd[:, 0], kd.sum(axis=1) + 2 * c_d.sum(axis=1) + 3 * td.sum(axis=1))


@pytest.mark.parametrize("entry, what", [("solve", "C damped modes"), ("solve_complex", "C complex damped modes")])
def test_a_failing_entry_raises_naming_it(monkeypatch, entry, what):
    fn = Recorder(cd.SOURCE, "et_damped" if entry == "solve" else "et_damped_complex", rc=-1)
    monkeypatch.setattr(cd, "driver", lambda: fn)
    monkeypatch.setattr(cd, "_COMPLEX", [fn])
    M, K, W, h, kd, c_d, td = poses_inputs(2)
    args = (M, K, W, h, kd, c_d, td) if entry == "solve" else (M, K, None, W, h, kd, c_d, td)
    with pytest.raises(RuntimeError) as err:
        getattr(cd, entry)(*args, 1.0, 2.0, 4.0)
    assert str(err.value) == f"{what} returned -1"


def numpy_wrenches(call, loss):
    """et_wrenches(_complex) by :func:`actuator_wrenches` on the arrays at the given addresses."""
    N, L, e, c = call["count"], call["L"], call["e"], call["c"]
    Je = doubles(call["Je"], N * L * e * c).reshape(N, L, e, c)
    Cq = doubles(call["Cq"], N * L * e * e).reshape(N, L, e, e)
    a0 = doubles(call["a0"], N * L).reshape(N, L) if loss else None
    eta = doubles(call["eta"], N) if loss else None
    assert call["rtol"] == RIGID
    K, W, h = actuator_wrenches(Je, Cq, a0, eta)
    for name, v in (("K", K), ("W", W), ("h", h)):
        out = doubles(call[name], v.size * (2 if loss else 1))
        out[:] = np.ascontiguousarray(v).reshape(-1).view(float) if loss else v.reshape(-1)


@pytest.mark.parametrize("loss", [None, 0.1])
def test_wrenches_marshal_the_legs_arrays(monkeypatch, loss):
    plain = Recorder(cd.SOURCE, "et_wrenches", effect=lambda c: numpy_wrenches(c, False))
    lossy = Recorder(cd.SOURCE, "et_wrenches_complex", effect=lambda c: numpy_wrenches(c, True))
    monkeypatch.setattr(cd, "driver", lambda: object())
    monkeypatch.setattr(cd, "_WRENCHES", [plain, lossy])
    rng = np.random.default_rng(1)
    Je = np.asfortranarray(rng.normal(size=(3, 2, 2, 6)))  # copied to C order for the driver
    A = rng.normal(size=(3, 2, 2, 2))
    Je = np.asfortranarray(np.round(10 * Je).astype(int))  # integers: read as doubles
    Cq = np.round(10 * (A @ np.swapaxes(A, -1, -2) + np.eye(2))).astype(int)
    a0 = np.array([2, 1])  # per leg, broadcast over the poses
    got = cd.wrenches(Je, Cq, RIGID, a0, None if loss is None else 1)
    want = actuator_wrenches(
        Je.astype(float),
        Cq.astype(float),
        np.broadcast_to(a0, (3, 2)).astype(float),
        None if loss is None else np.full(3, 1.0),
    )
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and np.allclose(g, w, rtol=1e-13)
    assert len((lossy if loss else plain).calls) == 1 and not (plain if loss else lossy).calls


def test_wrenches_within_the_drivers_sizes(monkeypatch):
    calls = []
    monkeypatch.setattr(cd, "driver", lambda: object())
    monkeypatch.setattr(cd, "_WRENCHES", [lambda *a: calls.append(a) or 0])
    for e, c, takes in ((cd.MAX_MODES, 64, True), (cd.MAX_MODES + 1, 6, False), (1, 65, False)):
        out = cd.wrenches(np.zeros((1, 1, e, c)), np.zeros((1, 1, e, e)), RIGID)
        assert (out is not None) is takes, (e, c)
        if takes:
            assert [x.shape for x in out] == [(1, c, c), (1, 1, c), (1, 1)]
    monkeypatch.setattr(cd, "_WRENCHES", [lambda *a: 5])
    with pytest.raises(RuntimeError) as err:
        cd.wrenches(np.zeros((1, 1, 1, 6)), np.zeros((1, 1, 1, 1)), RIGID)
    assert str(err.value) == "C actuator wrenches returned 5"


def legs_kernel(n):
    inputs, strides = np.array([11, 12], dtype=np.uint64), np.array([0, 1], dtype=np.int64)
    q_of = np.array([-1, 2, 3], dtype=np.intc)
    outs = {"Je": np.zeros((n, 2, 3, 6)), "Cq": np.zeros((n, 2, 3, 3)), "K_ground": np.zeros((n, 6, 6))}
    return (999, inputs, strides, q_of, outs, [])


def test_legs_arguments():
    legs = legs_kernel(4)
    args, keep = cd._legs_arguments(legs, 4)
    address, inputs, strides, q_of, outs, _ = legs
    assert args[:2] == (999, 3) and args[2:5] == (inputs.ctypes.data, strides.ctypes.data, q_of.ctypes.data)
    assert args[5] == 3 and args[6] == keep[0].ctypes.data and args[7] == keep[1].ctypes.data
    assert keep[0].tolist() == [a.ctypes.data for a in outs.values()] and keep[0].dtype == np.uint64
    assert keep[1].tolist() == [36, 18, 36] and keep[1].dtype == np.int64
    _, keep = cd._legs_arguments(legs_kernel(0), 0)
    assert keep[1].tolist() == [0, 0, 0]
    _, keep = cd._legs_arguments(legs_kernel(1), 1)
    assert keep[1].tolist() == [36, 18, 36]


def fused(n):
    return 777, ("in", "stride", 1, "ik", "mat", "jac", "freq", "vec", "status", "opts")


def pass_arrays(n, L=2, e=3):
    return dict(
        q=np.zeros((n, L, 3)),
        M=np.zeros((n, 6, 6)),
        K=np.zeros((n, 6, 6)),
        Je=np.zeros((n, L, e, 6)),
        Cq=np.zeros((n, L, e, e)),
    )


@pytest.mark.parametrize("B", [None, np.eye(6)[:, :4]])
def test_one_pass_hands_each_array_to_its_parameter(monkeypatch, B):
    n, block = 3 * MIN_BLOCKS_PER_THREAD * 4, 4
    seen = {}

    def read(c):  # the servo arrays and B of the range, read while the call runs; flags written
        m, a = c["end"] - c["begin"], c["begin"]
        for name in ("kd", "cd", "td"):
            seen.setdefault(name, []).append(doubles(c[name] + 8 * 2 * a, 2 * m).copy())
        seen.setdefault("sizes", []).append(doubles(c["l_size"], 3, ctypes.c_int64).tolist())
        if c["B"] is not None:
            seen.setdefault("B", []).append(doubles(c["B"], 6 * c["r"]).copy())
        doubles(c["stable"] + a, m, ctypes.c_int8)[:] = np.arange(a, a + m) % 2
        doubles(c["redo"] + a, m, ctypes.c_int8)[:] = np.arange(a, a + m) % 3

    fn = Recorder(cd.SOURCE, "et_damped_pass", effect=read)
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_PASS", [fn])
    a = pass_arrays(n)
    rules = (1.0, 2.0, 3.0, 4.0)
    B = None if B is None else B.astype(int)  # integers: read as doubles
    wn, zeta, wd, poles, stable, redo = cd.one_pass(
        fused(n),
        legs_kernel(n),
        block,
        n,
        a["q"],
        a["M"],
        a["K"],
        a["Je"],
        a["Cq"],
        2,
        B,
        5,
        np.ones(2),
        0.1,
        rules,
        threads=2,
    )
    r = 6 if B is None else 4
    assert wn.shape == (n, r) and poles.dtype == complex and stable.dtype == bool and redo.dtype == bool
    assert len(fn.calls) > 1
    ranges = sorted((c["begin"], c["end"]) for c in fn.calls)
    assert ranges[0][0] == 0 and ranges[-1][1] == n and all(x[1] == y[0] for x, y in zip(ranges, ranges[1:]))
    (c,) = [c for c in fn.calls if c["begin"] == 0]
    assert (c["block"], c["fused"], c["f_in"], c["f_stride"], c["f_model"], c["f_opts"]) == (
        block,
        777,
        "in",
        "stride",
        1,
        "opts",
    )
    assert (c["legs"], c["n_in"], c["n_out"], c["q_row"]) == (999, 3, 3, 6)
    assert (c["q"], c["Mall"], c["Kall"]) == (a["q"].ctypes.data, a["M"].ctypes.data, a["K"].ctypes.data)
    assert (c["Je"], c["Cq"], c["L"], c["e"], c["e_used"], c["r"]) == (
        a["Je"].ctypes.data,
        a["Cq"].ctypes.data,
        2,
        3,
        2,
        r,
    )
    assert (c["B"] is None) == (B is None)
    assert (c["rtol"], c["eliminate"], c["unstable"], c["ambiguous"]) == rules
    for name, value in (("kd", 5.0), ("cd", 1.0), ("td", 0.1)):
        assert np.array_equal(np.concatenate(seen[name]), np.full(2 * n, value)), name
    assert all(sizes == [36, 18, 36] for sizes in seen["sizes"])
    if B is not None:
        assert all(np.array_equal(b, B.ravel()) for b in seen["B"])
    assert np.array_equal(stable, np.arange(n) % 2 == 1) and np.array_equal(redo, np.arange(n) % 3 != 0)
    outputs = (wn, zeta, wd, poles, stable, redo)
    assert [c[k] for k in ("wn", "zeta", "wd", "poles")] == [x.ctypes.data for x in outputs[:4]]
    calls = len(fn.calls)
    cd.one_pass(fused(n), legs_kernel(n), block, n, a["q"], a["M"], a["K"], a["Je"], a["Cq"], 2, B, 5, 1.0, 0.1, rules)
    assert len(fn.calls) == calls + 1  # one thread unless asked
    fn.rc = 3
    with pytest.raises(RuntimeError) as err:
        cd.one_pass(
            fused(n), legs_kernel(n), block, n, a["q"], a["M"], a["K"], a["Je"], a["Cq"], 2, B, 5.0, 1.0, 0.1, rules
        )
    assert str(err.value) == "C damped pass returned 3"


@pytest.mark.parametrize("shared", [False, True])
def test_solve_legs_hands_each_array_to_its_parameter(monkeypatch, shared):
    """Per-pose K, K_ground and B at the range's first pose, or one shared (2-D) array read
    whole by every pose (its flag set); K None: the legs' own stiffness (NULL)."""
    N, L, e, r = 2 * MIN_BLOCKS_PER_THREAD * cd.BLOCK, 2, 3, 4
    seen = []

    def read(c):
        m = c["count"]
        servo = [doubles(c[k], L * m).copy() for k in ("kd", "cd", "td")]
        b = doubles(c["B"], 6 * r * (1 if c["B_shared"] else m)).copy()
        seen.append((c, servo, doubles(c["M"], 36 * m).copy(), doubles(c["Je"], L * e * 6 * m).copy(), b))
        doubles(c["wn"], r * m)[:] = doubles(c["M"], 36 * m).reshape(m, 36)[:, :r].ravel()
        doubles(c["status"], m, ctypes.c_int8)[:] = 1
        doubles(c["stable"], m, ctypes.c_int8)[:] = 0

    fn = Recorder(cd.SOURCE, "et_damped_legs", effect=read)
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_LEGS", [fn])
    M = np.arange(N * 36).reshape(N, 6, 6)  # integers: read as doubles
    Je = np.arange(N * L * e * 6).reshape(N, L, e, 6)
    Cq = np.zeros((N, L, e, e))
    Kg = np.ones((6, 6)) if shared else np.ones((N, 6, 6))
    B = np.eye(6)[:, :r] if shared else np.broadcast_to(np.eye(6)[:, :r], (N, 6, r))
    K = None if shared else np.zeros((N, 6, 6))
    wn, zeta, wd, poles, stable, redo = cd.solve_legs(M, K, Kg, Je, Cq, 2, B, 5, np.ones(L), 0.1, (1, 2, 3, 4), 2)
    assert len(seen) > 1 and sum(c["count"] for c, *_ in seen) == N
    assert np.array_equal(wn, M.reshape(N, 36)[:, :r]) and redo.all() and not stable.any()
    assert wn.shape == (N, r) and poles.shape == (N, r) and poles.dtype == complex
    for c, servo, m, je, b in seen:
        start = int(m[0]) // 36  # M[i] holds 36 i, 36 i + 1, ...
        assert np.array_equal(m, M[start : start + c["count"]].ravel())
        assert np.array_equal(je, Je[start : start + c["count"]].ravel())
        assert np.array_equal(b, (B if shared else B[start : start + c["count"]]).ravel())
        assert (c["Cq"] - Cq.ctypes.data) == 8 * start * L * e * e
        servo_values = [x.tolist() for x in servo]
        assert servo_values == [[v] * (L * c["count"]) for v in (5.0, 1.0, 0.1)]
        assert (c["L"], c["e"], c["e_used"], c["r"]) == (L, e, 2, r)
        assert (c["rtol"], c["eliminate"], c["unstable"], c["ambiguous"]) == (1, 2, 3, 4)
        assert (c["K_shared"], c["Kg_shared"], c["B_shared"]) == ((0, 1, 1) if shared else (0, 0, 0))
        if shared:
            assert c["K"] is None and c["Kg"] == Kg.ctypes.data
        else:
            assert c["K"] == K.ctypes.data + 8 * 36 * start and c["Kg"] == Kg.ctypes.data + 8 * 36 * start
        for name, out in (("wn", wn), ("zeta", zeta), ("wd", wd)):
            assert c[name] == out.ctypes.data + 8 * r * start
        assert c["poles"] == poles.ctypes.data + 16 * r * start
    fn.rc = 2
    with pytest.raises(RuntimeError) as err:
        cd.solve_legs(M, K, Kg, Je, Cq, 2, B, 5.0, 1.0, 0.1, (1, 2, 3, 4))
    assert str(err.value) == "C damped modes from the legs returned 2"


@pytest.mark.parametrize("damped, vectors", [(True, True), (False, False)])
def test_exact_pass_hands_each_array_to_its_parameter(monkeypatch, damped, vectors):
    n, block, L, e = 8, 4, 2, 3
    seen = []

    def write(c):
        seen.append(c)
        m = c["end"] - c["begin"]
        assert doubles(c["l_size"], 3, ctypes.c_int64).tolist() == [36, 18, 36]
        if c["kd"] is not None:
            seen.append(doubles(c["kd"] + 8 * L * c["begin"], L * m).copy())
        doubles(c["nb"] + c["begin"], m, ctypes.c_int8)[:] = 5
        doubles(c["stable"] + c["begin"], m, ctypes.c_int8)[:] = 1

    fn = Recorder(cd.SOURCE, "et_exact_pass", effect=write)
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_EXACT", [fn])
    legs = legs_kernel(n)
    q, M = np.zeros((n, L, 3)), np.zeros((n, 6, 6))
    servo = (7, 1.0, 0.1) if damped else (None, None, None)  # an integer k_d: read as doubles
    out = cd.exact_pass(fused(n), legs, block, n, q, M, *servo, (1.0, 2.0, 3.0, 4.0), 1e-7, vectors)
    c = seen[0]
    assert (c["rtol"], c["null_rtol"], c["eliminate"], c["unstable"], c["ambiguous"]) == (1.0, 1e-7, 2.0, 3.0, 4.0)
    outs = legs[4]
    assert (c["Je"], c["Cq"], c["Kg"]) == tuple(outs[k].ctypes.data for k in ("Je", "Cq", "K_ground"))
    assert (c["L"], c["e"], c["q_row"], c["legs"], c["fused"], c["block"]) == (L, e, 6, 999, 777, block)
    assert (c["begin"], c["end"]) == (0, n) and c["Mall"] == M.ctypes.data and c["q"] == q.ctypes.data
    assert out["nb"].dtype == int and out["nb"].tolist() == [5] * n
    assert out["lam"].shape == (n, 6) and out["code"].shape == (n,)
    assert (out["V"] is not None) is vectors and (c["V"] is not None) is vectors
    if vectors:
        assert out["V"].shape == (n, 6, 6) and c["V"] == out["V"].ctypes.data
    if damped:
        assert seen[1].tolist() == [7.0] * (L * n)
        wn, zeta, wd, poles, stable = out["damped"]
        assert stable.dtype == bool and stable.all() and wn.shape == (n, 6) and poles.dtype == complex
        assert c["cd"] is not None and c["td"] is not None
    else:
        assert "damped" not in out and c["kd"] is None and c["cd"] is None and c["td"] is None
    fn.rc = 4
    with pytest.raises(RuntimeError) as err:
        cd.exact_pass(fused(n), legs, block, n, q, M, *servo, (1.0, 2.0, 3.0, 4.0), 1e-7, vectors)
    assert str(err.value) == "C exact pass returned 4"


def test_solve_legs_of_the_six_twists_on_one_thread_by_default(monkeypatch):
    N, L, e = 2 * MIN_BLOCKS_PER_THREAD * cd.BLOCK, 1, 1

    def write(c):
        doubles(c["stable"], c["count"], ctypes.c_int8)[:] = 1
        doubles(c["status"], c["count"], ctypes.c_int8)[:] = 0

    fn = Recorder(cd.SOURCE, "et_damped_legs", effect=write)
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_LEGS", [fn])
    z = np.zeros
    wn, zeta, wd, poles, stable, redo = cd.solve_legs(
        z((N, 6, 6)), None, None, z((N, L, e, 6)), z((N, L, e, e)), 1, None, 1.0, 1.0, 0.0, (1, 2, 3, 4)
    )
    assert len(fn.calls) == 1 and fn.calls[0]["r"] == 6 and fn.calls[0]["B"] is None and fn.calls[0]["Kg"] is None
    assert wn.shape == (N, 6) and stable.dtype == bool and stable.all() and redo.dtype == bool and not redo.any()


@pytest.mark.parametrize("threads", [None, 2])
def test_exact_pass_flags_and_ranges(monkeypatch, threads):
    n, block = 2 * MIN_BLOCKS_PER_THREAD * 4, 4

    def write(c):
        a, m = c["begin"], c["end"] - c["begin"]
        for name in ("nb", "redo", "stable"):  # redo: the pose's code
            doubles(c[name] + a, m, ctypes.c_int8)[:] = np.arange(a, a + m) % 3
        doubles(c["lam"] + 8 * 6 * a, 6 * m)[:] = np.repeat(np.arange(a, a + m), 6)

    fn = Recorder(cd.SOURCE, "et_exact_pass", effect=write)
    monkeypatch.setattr(cd, "driver", lambda: None)
    monkeypatch.setattr(cd, "_EXACT", [fn])
    more = {} if threads is None else {"threads": threads}
    out = cd.exact_pass(
        fused(n),
        legs_kernel(n),
        block,
        n,
        np.zeros((n, 2, 3)),
        np.zeros((n, 6, 6)),
        1.0,
        1.0,
        0.0,
        (1, 2, 3, 4),
        1e-7,
        False,
        **more,
    )
    assert (len(fn.calls) == 1) is (threads is None)
    assert all(c["begin"] % block == 0 for c in fn.calls)
    flags = np.arange(n) % 3
    assert np.array_equal(out["nb"], flags) and np.array_equal(out["code"], flags)
    assert np.array_equal(out["damped"][4], flags != 0) and out["damped"][3].shape == (n, 6)
    assert np.array_equal(out["lam"], np.repeat(np.arange(n), 6).reshape(n, 6).astype(float))
