"""The evaluator's C paths: checks inside the fused pass, threads bit-identical to
one thread, outputs written in place, the gravity preload through C, unstable modes; each
against the NumPy backend. The NumPy-only parts (unstable modes, chunked matrices) run
without a compiler.
"""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist
from eigentwist.cli.main import main
from eigentwist.runtime import SingularPoseError, UnreachablePoseError, UnstablePoseError
from eigentwist.runtime.eigen import ROUNDOFF_EPS, frequencies_hz, generalized_eigh, unstable_modes
from eigentwist.runtime.validity import STATUS

from .conftest import c_cache_dir, compiled_tier, random_poses

compiled = pytest.mark.compiled
# a heavy payload at low actuator stiffness: gravity softens the vertical mode below zero
UNSTABLE = dict(g=50.0, k_a=50.0, m_p=100.0, p_z=0.3)
UNSTABLE_MODEL = "paper,gravity_preload,payload_mass"


@pytest.fixture(scope="module")
def ev_c():
    mp = compiled_tier()
    yield eigentwist.load("heli4", backend="c", threads=1)
    mp.undo()


def assert_freq_close(got, want, rtol=1e-12):
    """Equal NaN places, and |got - want| <= rtol * the pose's highest frequency (the two
    backends' eigen-solvers, Jacobi and LAPACK, differ by round-off of that size)."""
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    finite = np.where(np.isnan(want), 0.0, np.abs(want))
    scale = np.maximum(finite.max(axis=-1, keepdims=True), 1e-300)
    err = np.nan_to_num(np.abs(got - want) / scale)
    assert err.max() <= rtol, f"max deviation {err.max():.2e} of the pose's highest frequency"


def _poses(ev, n, seed, bad=()):
    poses = random_poses(ev.robot, n, seed)
    for k in bad:
        poses[k] = (0.0, 0.0, 0.0)  # too close to the base: unreachable
    return poses


# ------------------------------------------------------------ no compiler needed
def test_round_off_clips_to_zero_and_negative_stiffness_is_nan():
    lam = np.array([[-1e-12, 4.0, 1e3], [-5.0, 4.0, 1e3], [0.0, 0.0, 0.0]])
    assert unstable_modes(lam).tolist() == [[False] * 3, [True, False, False], [False] * 3]
    f = frequencies_hz(lam)
    assert f[0, 0] == 0.0 and np.isnan(f[1, 0]) and (f[2] == 0.0).all()
    np.testing.assert_allclose(f[:2, 1:], np.sqrt([[4.0, 1e3]] * 2) / (2 * np.pi), rtol=1e-15)
    edge = np.array([[-0.99 * ROUNDOFF_EPS * 1e3, 1e3], [-1.01 * ROUNDOFF_EPS * 1e3, 1e3]])
    assert unstable_modes(edge)[:, 0].tolist() == [False, True]


def test_unstable_model_is_nan_with_a_flag_not_zero_hz(ev):
    poses = np.array([[0.0, 0.0, -0.625], [0.05, 0.02, -0.6]])
    m = ev.modes(poses, UNSTABLE_MODEL, **UNSTABLE)
    assert not m.stable.any()
    assert np.isnan(m.freq_hz[:, 0]).all() and np.isfinite(m.freq_hz[:, 1:]).all()
    M, K = ev.stiffness(poses, UNSTABLE_MODEL, **UNSTABLE)
    assert (np.linalg.eigvalsh(K)[:, 0] < 0).all()  # K itself is indefinite there
    ok = ev.modes(poses, UNSTABLE_MODEL, **{**UNSTABLE, "m_p": 0.2})
    assert ok.stable.all() and np.isfinite(ok.freq_hz).all()
    with pytest.raises(
        UnstablePoseError, match=r"pose \[0.0, 0.0, -0.625\] m is unstable .*mode 1 of 6 has a negative"
    ):
        ev.modes(poses, UNSTABLE_MODEL, unstable="raise", **UNSTABLE)


def test_cli_matrices_names_the_unstable_pose_and_mode(capsys):
    rc = main(
        [
            "matrices",
            "--backend",
            "numpy",
            "--model",
            "rigid,gravity_preload,payload_mass",
            "--set",
            "g=50",
            "--set",
            "m_p=100",
            "--set",
            "p_z=0.3",
            "--k-a",
            "50",
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert "pose [0.0, 0.0, -0.625] m is unstable" in err and "mode 1 of 3" in err


def test_numpy_matrices_into_out_and_in_chunks(ev):
    poses = random_poses(ev.robot, 300, seed=3)
    k_a = np.linspace(500.0, 3000.0, 300)
    want = ev.matrices(poses, "paper", k_a=k_a)
    out = {"K_F": np.zeros((300, 6, 6))}
    got = ev.matrices(poses, "paper", out=out, k_a=k_a)
    assert got["K_F"] is out["K_F"]
    for key in want:
        np.testing.assert_array_equal(got[key], want[key])
    chunks = list(ev.iter_matrices(poses, "paper", chunk=128, k_a=k_a))
    assert [sl.start for sl, _ in chunks] == [0, 128, 256]
    for sl, mats in chunks:
        for key in want:
            np.testing.assert_array_equal(mats[key], want[key][sl])
    with pytest.raises(ValueError, match=r"out\['M'\].*\(300, 6, 6\)"):
        ev.matrices(poses, out={"M": np.zeros((299, 6, 6))})
    with pytest.raises(ValueError, match="chunk"):
        next(ev.iter_matrices(poses, chunk=0))


def test_modes_without_vectors(ev):
    poses = random_poses(ev.robot, 50, seed=4)
    m = ev.modes(poses, "paper", vectors=False)
    assert m.eigentwists is None
    np.testing.assert_array_equal(m.freq_hz, ev.modes(poses, "paper").freq_hz)  # bit for bit


# ---------------------------------------------------------------- compiled tier
@compiled
@pytest.mark.parametrize("model", ["paper", "rigid", "coupled", "paper,lower_link_compliance,payload_mass"])
def test_public_path_equals_numpy(ev_c, ev, model):
    poses = _poses(ev, 517, seed=40)
    k_a = np.random.default_rng(41).uniform(200.0, 5000.0, len(poses))
    mc, mn = ev_c.modes(poses, model, k_a=k_a), ev.modes(poses, model, k_a=k_a)
    assert_freq_close(mc.freq_hz, mn.freq_hz)
    np.testing.assert_allclose(mc.eigentwists, mn.eigentwists, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(ev_c.frequencies(poses, model, k_a=k_a), mc.freq_hz)  # no vectors: same bits
    assert mc.stable.all() and mc.valid is None


@compiled
def test_checks_in_the_c_pass_match_numpy(ev_c, ev):
    poses = _poses(ev, 300, seed=42, bad=(7, 200))
    mc, mn = ev_c.modes(poses, invalid="nan"), ev.modes(poses, invalid="nan")
    np.testing.assert_array_equal(mc.valid, mn.valid)
    assert mc.valid.sum() == 298
    assert_freq_close(mc.freq_hz, mn.freq_hz)  # NaN in the same places
    np.testing.assert_array_equal(ev_c.valid(poses), ev.valid(poses))
    for evaluator in (ev_c, ev):
        with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, 0.0\] m is unreachable for leg"):
            evaluator.frequencies(poses)
        with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, 0.0\] m is unreachable for leg"):
            evaluator.matrices(poses)


@compiled
def test_singular_pose_is_found_in_the_c_pass(ev_c, monkeypatch):
    import eigentwist.runtime.validity as validity

    monkeypatch.setattr(validity, "LEVER_TOL", 10.0)  # every lever counts as vanishing
    with pytest.raises(SingularPoseError, match=r"pose \[0.0, 0.0, -0.625\] m is serial singular for leg 1"):
        ev_c.frequencies([[0.0, 0.0, -0.625]])
    assert not ev_c.valid([[0.0, 0.0, -0.625]])[0]


@compiled
@pytest.mark.parametrize("threads", [2, 3])
def test_threads_give_bit_identical_results(ev_c, ev, threads):
    n = 64 * 16 * threads * 2 + 37  # several ranges, a partial last block
    poses = _poses(ev, n, seed=43, bad=(5, 1500))
    k_a = np.random.default_rng(44).uniform(200.0, 5000.0, n)
    many = eigentwist.load("heli4", backend="c", threads=threads)
    assert many._kernels is not None and many.threads == threads
    for model in ("paper", "rigid"):
        one, par = ev_c.modes(poses, model, invalid="nan", k_a=k_a), many.modes(poses, model, invalid="nan", k_a=k_a)
        for a, b in ((one.freq_hz, par.freq_hz), (one.eigentwists, par.eigentwists), (one.valid, par.valid)):
            assert a.tobytes() == b.tobytes()
    ok = one.valid
    shifted = np.empty((n, 4))  # other addresses and strides: the same bits
    shifted[:, 1:] = poses
    other = many.modes(shifted[:, 1:], "rigid", invalid="nan", k_a=k_a.copy())
    assert other.freq_hz.tobytes() == one.freq_hz.tobytes()
    m1, m2 = ev_c.matrices(poses[ok], k_a=k_a[ok]), many.matrices(poses[ok], k_a=k_a[ok])
    assert all(m1[k].tobytes() == m2[k].tobytes() for k in m1)
    g1 = ev_c.modes(poses[ok], "paper,gravity_preload", k_a=k_a[ok])
    g2 = many.modes(poses[ok], "paper,gravity_preload", k_a=k_a[ok])
    assert g1.freq_hz.tobytes() == g2.freq_hz.tobytes() and g1.eigentwists.tobytes() == g2.eigentwists.tobytes()


@compiled
@pytest.mark.parametrize("robot, bad", [("heli4", (0.0, 0.0, 0.0)), ("hexapod", (0.0,) * 6)])
def test_the_scheduled_pass_gives_the_same_bits_on_any_threads_and_by_ranges(robot, bad, monkeypatch):
    """The prepared pass (scalar parameters) with its blocks handed out in C on 1, 2 and 3
    threads, and by ranges from Python: the same bits (frequencies, eigentwists, validity),
    past many grains with a partial last block and invalid poses among them."""
    from eigentwist.runtime import c_schedule
    from eigentwist.runtime.fused_call import FusedCall

    one = eigentwist.load(robot, backend="c", threads=1)
    n = 64 * c_schedule.GRAIN_BLOCKS * 40 + 37
    poses = random_poses(one.robot, n, seed=46)
    poses[::97] = bad  # unreachable or singular poses
    scheduled = []
    monkeypatch.setattr(FusedCall, "screened", _counted(FusedCall.screened, scheduled))
    want = {m: one.modes(poses, m, invalid="nan") for m in ("paper", "none")}
    assert len(scheduled) == 2 and c_schedule.scheduler() is not None
    assert 0 < np.count_nonzero(want["none"].valid) < n
    for threads in (2, 3, "ranges"):
        if threads == "ranges":
            monkeypatch.setattr(c_schedule, "scheduler", lambda: None)
        ev = eigentwist.load(robot, backend="c", threads=2 if threads == "ranges" else threads)
        for m, w in want.items():
            got = ev.modes(poses, m, invalid="nan")
            for a, b in ((w.freq_hz, got.freq_hz), (w.eigentwists, got.eigentwists), (w.valid, got.valid)):
                assert a.tobytes() == b.tobytes()
    assert len(scheduled) == 2 + 3 * 2


@compiled
def test_the_general_pass_counts_its_clean_poses(ev_c):
    """``CKernels.fused(..., screen=s)``: ``clean`` where every pose has status 0 and its lowest
    frequency above s times its highest; not where one pose is unreachable or the screen is
    above the lowest's ratio; absent without a screen. ``modes`` on the general route (values
    per pose) then skips its checks or runs them: the same frequencies either way."""
    from eigentwist.runtime.c_route import PARALLEL_SCREEN

    poses = random_poses(ev_c.robot, 3000, seed=47)
    poses = poses[ev_c.valid(poses, "paper")]
    p = ev_c.completion.with_pose(poses, ev_c.parameter_values(len(poses)))
    kw = dict(model="flexible", status=True, threads=2, matrices=())
    out = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, screen=PARALLEL_SCREEN, **kw)
    ratio = (out["freq_hz"][:, 0] / out["freq_hz"][:, -1]).min()
    assert out["clean"] is True and ratio > PARALLEL_SCREEN
    assert "clean" not in ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, **kw)
    above = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, screen=1.01 * ratio, **kw)
    below = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, screen=0.99 * ratio, **kw)
    assert above["clean"] is False and below["clean"] is True
    far = poses.copy()
    far[len(far) // 2, 2] = 5.0  # unreachable
    pf = ev_c.completion.with_pose(far, ev_c.parameter_values(len(far)))
    assert ev_c.kernels.fused(far[:, 0], far[:, 1], far[:, 2], pf, screen=PARALLEL_SCREEN, **kw)["clean"] is False
    k_a = np.full(len(far), 1000.0)  # values per pose: the general route
    m = ev_c.modes(far, "paper", invalid="nan", k_a=k_a)
    assert not m.valid[len(far) // 2] and m.valid.sum() == len(far) - 1
    clean = ev_c.modes(poses, "paper", invalid="nan", k_a=k_a[: len(poses)])
    assert clean.valid.all() and np.array_equal(clean.freq_hz[: len(far) // 2], m.freq_hz[: len(far) // 2])


@compiled
def test_the_general_pass_fills_every_output_the_same_scheduled_or_by_ranges(ev_c, monkeypatch):
    """``CKernels.fused`` asked for every output (joint coordinates, M and K_F, the Jacobian
    rows, frequencies, eigentwists, status) on two threads: the C scheduler's blocks and the
    Python ranges give the same bits in each, an unreachable pose among them."""
    from eigentwist.runtime import c_schedule

    poses = random_poses(ev_c.robot, 64 * c_schedule.GRAIN_BLOCKS * 12 + 9, seed=48)
    poses[100, 2] = 5.0  # unreachable
    p = ev_c.completion.with_pose(poses, ev_c.parameter_values(len(poses)))
    kw = dict(matrices=("M", "K_F"), ik=("q",), jacobians=("J_rows",), model="flexible", vectors=True)
    kw.update(status=True, normalize=True, threads=2)
    scheduled = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, **kw)
    monkeypatch.setattr(c_schedule, "scheduler", lambda: None)
    ranges = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, **kw)
    assert sorted(scheduled) == sorted(ranges) and {"q", "M", "K_F", "J_rows", "eigentwists"} <= set(ranges)
    ok = ranges["status"] == 0
    assert not ok[100] and ok.sum() == len(poses) - 1
    for name, value in ranges.items():
        assert value[ok].tobytes() == scheduled[name][ok].tobytes(), name


@compiled
@pytest.mark.parametrize("model", ["paper", "rigid"])
def test_the_general_pass_marks_its_stable_poses_stable(ev_c, model):
    """``Modes.stable`` on the C pass's general route (values per pose) in a batch that is not
    clean (an unreachable pose): True on every pose whose frequencies are finite, as on the
    NumPy backend; the unreachable pose invalid."""
    poses = random_poses(ev_c.robot, 300, seed=51)
    poses = poses[ev_c.valid(poses, model)]
    poses[5, 2] = 5.0  # unreachable
    k_a = np.full(len(poses), 1500.0)
    m = ev_c.modes(poses, model, invalid="nan", k_a=k_a)
    assert not m.valid[5] and m.valid.sum() == len(poses) - 1
    assert m.stable[m.valid].all() and np.isfinite(m.freq_hz[m.valid]).all()
    numpy = eigentwist.load("heli4", backend="numpy").modes(poses, model, invalid="nan", k_a=k_a)
    assert np.array_equal(numpy.stable[m.valid], m.stable[m.valid])


@compiled
def test_a_failing_general_pass_names_itself(ev_c, monkeypatch):
    """A nonzero code of the general pass raises naming it, whether its blocks were handed
    out in C (a schedule left with -2: out of memory) or run by ranges (another code)."""
    from eigentwist.runtime import c_schedule

    poses = random_poses(ev_c.robot, 3000, seed=50)
    p = ev_c.completion.with_pose(poses, ev_c.parameter_values(len(poses)))
    failed = c_schedule.Schedule()
    failed.rc = -2
    monkeypatch.setattr(c_schedule, "run_pass", lambda *a, **kw: failed)
    with pytest.raises(MemoryError, match=r"^C fused: out of memory"):
        ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, model="flexible", status=True, threads=2)
    monkeypatch.setattr(c_schedule, "run_pass", lambda *a, **kw: None)  # no scheduler: by ranges
    monkeypatch.setitem(ev_c.kernels._fn, "fused", lambda *a: 3)
    with pytest.raises(RuntimeError, match=r"^C fused returned 3"):
        ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, model="flexible", status=True, threads=2)


def _counted(method, calls: list):
    """``method`` that appends to ``calls`` at each call."""

    def counted(*args, **kw):
        calls.append(1)
        return method(*args, **kw)

    return counted


@compiled
def test_c_matrices_into_out_and_in_chunks(ev_c, ev):
    poses = random_poses(ev.robot, 700, seed=45)
    want = ev.matrices(poses, "coupled", l2=0.55)
    out = {k: np.empty((700, 6, 6)) for k in ("M", "K_R", "K_F")}
    got = ev_c.matrices(poses, "coupled", out=out, l2=0.55)
    for k in want:
        assert got[k] is out[k]
        np.testing.assert_allclose(got[k], want[k], rtol=1e-12, atol=1e-12 * np.abs(want[k]).max())
    rows = np.concatenate([mats["K_F"] for _, mats in ev_c.iter_matrices(poses, "coupled", chunk=256, l2=0.55)])
    assert rows.tobytes() == got["K_F"].tobytes()


@compiled
@pytest.mark.parametrize("model", ["paper,gravity_preload,payload_mass", "rigid,gravity_preload"])
def test_gravity_preload_through_c_equals_numpy(ev_c, ev, model):
    poses = random_poses(ev.robot, 150, seed=46)
    kw = dict(k_a=np.linspace(300.0, 4000.0, 150), m_p=2.0, p_x=0.02)
    mc, mn = ev_c.modes(poses, model, **kw), ev.modes(poses, model, **kw)
    assert_freq_close(mc.freq_hz, mn.freq_hz)
    np.testing.assert_allclose(mc.eigentwists, mn.eigentwists, rtol=0, atol=1e-10)
    Mc, Kc = ev_c.stiffness(poses, model, **kw)
    Mn, Kn = ev.stiffness(poses, model, **kw)
    np.testing.assert_allclose(Kc, Kn, rtol=0, atol=1e-12 * np.abs(Kn).max())


@compiled
def test_unstable_model_in_c(ev_c, ev):
    poses = np.array([[0.0, 0.0, -0.625], [0.05, 0.02, -0.6]])
    mc, mn = ev_c.modes(poses, UNSTABLE_MODEL, **UNSTABLE), ev.modes(poses, UNSTABLE_MODEL, **UNSTABLE)
    assert not mc.stable.any()
    assert_freq_close(mc.freq_hz, mn.freq_hz)  # NaN in the same places
    # the fused pass (no gravity): a negative actuator stiffness, below any parameter check
    ck = ev_c._kernels
    poses = random_poses(ev.robot, 200, seed=47)
    p = ev.parameter_values(200, "rigid")
    p["k_a"] = np.where(np.arange(200) % 3 == 0, -1500.0, 1500.0)
    out = ck.fused(*poses.T, p, matrices=("M", "K_R"), model="rigid", status=True)
    lam = generalized_eigh(out["K_R"][:, 3:, 3:], out["M"][:, 3:, 3:])[0]
    assert (out["status"] == np.where(np.arange(200) % 3 == 0, STATUS["unstable"], STATUS["ok"])).all()
    assert_freq_close(out["freq_hz"], frequencies_hz(lam))
    assert np.isnan(out["freq_hz"][::3]).all()


@compiled
def test_packed_scalars_follow_the_values(ev_c):
    """The C pass packs its scalar inputs once and reuses them only for the very same
    read-only objects: a writeable 0-d array changed in place between calls is read anew."""
    poses = np.array([[0.0, 0.0, -0.625], [0.05, -0.03, -0.6]])
    p = ev_c.inputs("paper")
    p = {k: np.array(v) for k, v in p.items()}  # writeable 0-d arrays
    kw = dict(matrices=(), model="flexible", status=True)
    f1 = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, **kw)["freq_hz"].copy()
    p["k_a"][...] = 4.0 * p["k_a"]
    f2 = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], p, **kw)["freq_hz"]
    assert np.all(f2[:, 0] > f1[:, 0] * 1.05)
    frozen = ev_c.resolver.resolve(2, {}, "paper")  # read-only: packed once, reused
    a = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], frozen, **kw)["freq_hz"]
    b = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], ev_c.resolver.resolve(2, {}, "paper"), **kw)[
        "freq_hz"
    ]
    fresh = {k: np.array(v) for k, v in frozen.items()}  # writeable copies: packed anew
    c = ev_c.kernels.fused(poses[:, 0], poses[:, 1], poses[:, 2], fresh, **kw)["freq_hz"]
    assert np.array_equal(a, b) and np.array_equal(a, c)


@compiled
def test_parallel_screen_is_remembered_per_geometry(ev_c, monkeypatch):
    """The parallel-singularity screen is computed once per content of the poses and the
    inputs of the kernels it runs: a stiffness leaves it, a geometric parameter (l1) or a
    pose computes it anew, and the answer is always the one computed afresh."""
    import eigentwist.runtime.checks as checks

    ev_c.checks.parallel_memo = checks.BoundedMemo()
    calls = []
    rows_of = ev_c.checks.platform_rows
    monkeypatch.setattr(ev_c.checks, "platform_rows", lambda at, pp: calls.append(1) or rows_of(at, pp))
    # a screen that depends on the rows' values: a stale answer would differ from a fresh one
    monkeypatch.setattr(checks, "parallel_mask", lambda W: W[:, 0, 3] > -0.47)
    poses = np.array([[0.0, 0.0, -0.625], [0.05, -0.03, -0.6], [0.0, 0.0, -0.625]])
    idx = np.arange(3)

    def screen(poses=poses, **params):
        p = ev_c.resolver.resolve(len(poses), params, "paper")
        return ev_c.checks.parallel_ok(poses, p, idx, strict=False)

    def fresh(poses=poses, **params):
        p = ev_c.resolver.resolve(len(poses), params, "paper")
        return checks.parallel_mask(rows_of(poses, ev_c.completion.with_pose(poses, p)))

    assert "l1" in ev_c.checks.geometry_names() and "k_a" not in ev_c.checks.geometry_names()
    first = screen()
    assert len(calls) == 1 and np.array_equal(first, fresh())
    assert np.array_equal(screen(), first) and np.array_equal(screen(k_a=2000.0), first)
    assert len(calls) == 1  # same poses and geometry, another stiffness: remembered
    l1 = ev_c.parameter("l1").default
    longer = screen(l1=1.3 * l1)
    assert len(calls) == 2 and np.array_equal(longer, fresh(l1=1.3 * l1))
    assert list(first) == [False, True, False] and not longer.any()  # the geometry changes the answer
    moved = poses + [0.0, 0.0, 0.01]
    assert np.array_equal(screen(moved), fresh(moved)) and len(calls) == 3


def test_bounded_memo_empties_when_full():
    from eigentwist.runtime.memo import BoundedMemo, content_key

    memo = BoundedMemo(3)
    for k in range(3):
        memo.put(k, k)
    assert len(memo) == 3 and memo.get(0) == 0
    memo.put(3, 3)  # the fourth: the first three forgotten
    assert len(memo) == 1 and memo.get(0) is None and memo.get(3) == 3
    p = np.zeros((2, 3))
    assert content_key(p, {"a": 1.0}, ["a"]) == content_key(p.copy(), {"a": np.float64(1.0)}, ["a"])
    assert content_key(p, {"a": 1.0}, ["a"]) != content_key(p, {"a": 1.0 + 1e-15}, ["a"])
    assert content_key(p, {"a": np.ones(2)}, ["a"]) != content_key(p, {"a": np.array([1.0, 1.0 + 2e-16])}, ["a"])
    assert content_key(p, {}, ["a"]) != content_key(p, {"a": 0.0}, ["a"])


@compiled
def test_distinct_rows_evaluated_once_give_every_rows_numbers(ev_c):
    """Rows that share a pose and k_a are evaluated once: frequencies, matched modes and the
    damped modes equal those of every row evaluated (a damped model, labels x and y)."""
    from eigentwist.diagnose.predict import distinct_rows, evaluate

    poses = np.array([[0.0, 0.0, -0.625], [0.02, 0.0, -0.6], [0.0, 0.0, -0.625], [0.02, 0.0, -0.6], [0, 0, -0.625]])
    k_a = np.array([1000.0, 1000.0, 1000.0, 1000.0, 2000.0])
    labels = ["x", "x", "y", "y", "x"]
    unique = distinct_rows([poses, k_a], 5)
    assert [list(v) for v in unique] == [[0, 1, 4], [0, 1, 0, 1, 2]]
    model = ("actuator_loss", "ee_compliance", "servo_damping")
    params = {"k_a": k_a, "c_a": 2.0}
    damped = np.ones(5, dtype=bool)
    f, i, m = evaluate(ev_c, model, poses, labels, params, return_modes=True, damped=damped, unique=unique)
    g, j, n = evaluate(ev_c, model, poses, labels, params, return_modes=True, damped=damped)
    assert np.array_equal(f, g) and np.array_equal(i, j)
    assert np.array_equal(m.freq_hz, n.freq_hz) and np.array_equal(m.eigentwists, n.eigentwists)
    assert np.array_equal(m.damped_hz, n.damped_hz) and np.array_equal(m.damping_ratio, n.damping_ratio)
    assert distinct_rows([poses[:2], k_a[:2]], 2) is None  # all distinct
    nan = poses.copy()
    nan[2:4] = np.nan
    assert distinct_rows([nan, k_a], 5) is None  # NaN is never equal to itself


@compiled
def test_kernel_scalars_packed_once_follow_the_values(ev_c):
    """A kernel's scalar inputs are packed once and reused only for the very same read-only
    objects (the evaluator's defaults and switches): a writeable 0-d array changed in place
    between calls is read anew."""
    poses = np.array([[0.0, 0.0, -0.625], [0.05, -0.03, -0.6]])
    ev_c.resolver.resolve(2, {"k_a": np.array([900.0, 1100.0])}, "paper")  # the defaults' first use checks them
    frozen = ev_c.resolver.resolve(2, {"k_a": np.array([900.0, 1100.0])}, "paper")  # arrays: not memoised
    assert frozen["l1"] is ev_c.resolver.resolve(2, {"k_a": np.array([1.0, 2.0])}, "paper")["l1"]  # same default object
    q = ev_c.checks.ik(poses, frozen)
    a = ev_c.kernels.matrices(q, ev_c.completion.with_pose(poses, frozen))["K_F"]
    packed = ev_c.kernels._kernel_packed["matrices"]
    b = ev_c.kernels.matrices(q, ev_c.completion.with_pose(poses, frozen))["K_F"]
    assert ev_c.kernels._kernel_packed["matrices"] is packed and np.array_equal(a, b)
    p = {k: np.array(v) for k, v in frozen.items()}  # writeable copies: packed anew
    c = ev_c.kernels.matrices(q, ev_c.completion.with_pose(poses, p))["K_F"]
    p["l1"][...] = 1.5 * p["l1"]  # in place: the next call reads the new value
    d = ev_c.kernels.matrices(q, ev_c.completion.with_pose(poses, p))["K_F"]
    assert np.array_equal(a, c) and not np.allclose(c, d, rtol=1e-3)


@pytest.mark.parametrize(
    "pose, fused",
    [
        (("x", "y", "z"), True),  # a translational robot: the C pass's 3x3 blocks
        (("z", "x", "y"), True),  # in any order
        (("x", "y", "z", "rot_x", "rot_y", "rot_z"), True),  # a free platform: its six twists
        (("rot_z", "rot_y", "rot_x", "z", "y", "x"), True),
        (("x", "y", "rot_z"), False),  # planar: reduced in Python on its allowed twists
        (("z", "rot_x", "rot_y"), False),  # lower mobility
        (("x", "y"), False),  # a point in a plane
    ],
)
def test_the_rigid_model_takes_the_c_pass_for_translations_or_all_six_twists(pose, fused):
    from types import SimpleNamespace

    from eigentwist.runtime.c_route import CPassRoute

    stub = SimpleNamespace(space=SimpleNamespace(basis=(tuple(range(len(pose))),)), pose_names=pose)
    assert CPassRoute.c_rigid.fget(stub) is fused
    assert CPassRoute.c_rigid.fget(SimpleNamespace(space=SimpleNamespace(), pose_names=pose)) is False


# ------------------------------------------------- the prepared pass of small calls
def _same_modes(a, b) -> bool:
    fields = ("freq_hz", "eigentwists", "valid", "stable", "shares", "constrained")
    return (a.axes, a.stiffness_model) == (b.axes, b.stiffness_model) and all(
        (getattr(a, f) is None) == (getattr(b, f) is None)
        and (getattr(a, f) is None or np.asarray(getattr(a, f)).tobytes() == np.asarray(getattr(b, f)).tobytes())
        for f in fields
    )


def _outcome(ev, poses, model, **kw):
    try:
        return ev.modes(poses, model, **kw)
    except Exception as exc:  # the same error, word for word
        return f"{type(exc).__name__}: {exc}"


@compiled
@pytest.mark.parametrize("robot, bad", [("heli4", (0.0, 0.0, 0.0)), ("hexapod", (0.0,) * 6)])
def test_prepared_pass_gives_the_general_routes_bits(robot, bad, monkeypatch):
    """``modes`` of scalar values by the prepared C pass (``ev.c_route.plan``) equals the
    general route bit for bit, on both sides of each of its guards: a clean batch and one
    with an unreachable or singular pose (``invalid`` raise and nan), every pose through the
    parallel screen or none, a pose not finite, values per pose (no plan), a strided batch,
    one pose, several threads, a rotation vector below and above the series' threshold."""
    import eigentwist.runtime.c_route as c_route

    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    fast, many = (eigentwist.load(robot, backend="c", threads=t) for t in (1, 2))
    general = eigentwist.load(robot, backend="c", threads=1)
    monkeypatch.setattr(general.c_route, "plan", lambda *args: None)
    poses = random_poses(fast.robot, 2085, seed=46)  # > 16 blocks a thread on two threads
    poses = poses[fast.valid(poses, "paper") & fast.valid(poses, "rigid")]
    if robot == "hexapod":
        poses[3, 3:] = (1e-7, 0.0, 0.0)  # t^2 = 1e-14 < 1e-12: the series of sin(t)/t
    few, flagged = poses[:5], np.vstack([poses[:3], bad])
    strided = np.asfortranarray(poses[:9])
    cases = [
        (few, "paper", {}),
        (few, "rigid", dict(vectors=False)),
        (poses[7], "paper", dict(vectors=False)),
        (strided, "paper", dict(invalid="nan")),
        (flagged, "paper", dict(invalid="nan")),
        (flagged, "rigid", {}),
        (flagged[:, ::-1], "paper", {}),
        (np.where(few == few[0, 0], np.nan, few), "paper", {}),
        (few, "paper", dict(k_a=np.linspace(1500.0, 2500.0, 5))),
    ]
    for screen in (c_route.PARALLEL_SCREEN, 1.0):  # 1.0: every pose goes to the exact check
        monkeypatch.setattr(c_route, "PARALLEL_SCREEN", screen)
        for P, model, kw in cases:
            got, want = _outcome(fast, P, model, **kw), _outcome(general, P, model, **kw)
            assert type(got) is type(want), (model, kw, got, want)
            assert got == want if isinstance(got, str) else _same_modes(got, want), (model, kw)
    assert len(fast.c_route.plans) == 5  # one per (model, options); none for k_a per pose
    assert all(
        fast.c_route.plan(m, {}, inv, "nan", vec)
        for m, inv, vec in [("paper", "raise", True), ("rigid", "raise", False)]
    )
    assert fast.c_route.plan("paper", {"k_a": np.ones(5)}, "raise", "nan", True) is None
    if robot == "hexapod":
        clean = poses[4:9]
        assert _same_modes(fast.modes(clean, "paper"), general.modes(clean, "paper"))
    big = many.modes(poses, "paper", vectors=False)
    assert big.freq_hz.tobytes() == general.modes(poses, "paper", vectors=False).freq_hz.tobytes()


def _rodrigues_reference(r):
    """The nine entries of R = I + a [r]x + b [r]x^2 of rotation vectors r (N, 3), written
    out here, with the series of a = sin(t)/t and b = (1 - cos t)/t^2 below t^2 = 1e-12."""
    x, y, z = r[:, 0], r[:, 1], r[:, 2]
    xx, yy, zz = x * x, y * y, z * z
    t2 = xx + yy + zz
    small = t2 < 1e-12
    safe = np.where(small, 1.0, np.sqrt(t2))
    a = np.where(small, 1 - t2 / 6, np.sin(safe) / safe)
    b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(safe)) / safe**2)
    ax, ay, az, bxy, bxz, byz = a * x, a * y, a * z, b * (x * y), b * (x * z), b * (y * z)
    return [
        1 + b * (-zz - yy), -az + bxy, ay + bxz, az + bxy, 1 + b * (-zz - xx),
        -ax + byz, -ay + bxz, ax + byz, 1 + b * (-yy - xx),
    ]  # fmt: skip


#: rotation vectors just inside and just outside the series' threshold t^2 = 1e-12, and zero
_NEAR_ZERO = np.array([[0.999e-6, 0.0, 0.0], [1.001e-6, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, -5e-7, 5e-7]])


def test_rotation_entries_are_rodrigues_bit_for_bit():
    """``rotation_entries`` gives the bits of Rodrigues' formula as written here, with its
    series selected below t^2 = 1e-12 (batches with and without such a vector, just below
    and just above the threshold)."""
    from eigentwist.runtime.poses import rotation_entries

    r = np.random.default_rng(47).normal(size=(40, 3))
    for batch in (r, np.vstack([r, _NEAR_ZERO[0]]), np.vstack([r, _NEAR_ZERO[1]])):
        assert [w.tobytes() for w in _rodrigues_reference(batch)] == [e.tobytes() for e in rotation_entries(batch)]
    R = np.array(rotation_entries([0.0, 0.0, np.pi / 2])).reshape(3, 3)  # a quarter turn about z
    np.testing.assert_allclose(R, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)


@compiled
def test_the_pass_computes_the_rotation_from_the_rotation_vector(monkeypatch):
    """The hexapod's C pass given the rotation vector (``rot_x, rot_y, rot_z``; it computes
    the R_ij it reads, per block) equals the pass given R_ij from Rodrigues' formula written
    here (every R_ij input read), on random poses and rotation vectors just inside and
    outside the series' threshold and zero: joint coordinates, M, K_F and frequencies to
    1e-13 relative (a rotation entry's round-off is ~1e-16); a partial block and a full one."""
    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    ev = eigentwist.load("hexapod", backend="c", threads=1)
    poses = random_poses(ev.robot, 80, seed=48)
    poses[[5, 17, 66, 79], 3:] = _NEAR_ZERO
    p = ev.parameter_values(1, "paper")
    x, y, z = poses[:, :3].T
    by_matrix = {
        **p,
        **dict(zip([f"R_{i}{j}" for i in range(3) for j in range(3)], _rodrigues_reference(poses[:, 3:]))),
    }
    by_vector = {**p, "rot_x": poses[:, 3], "rot_y": poses[:, 4], "rot_z": poses[:, 5]}
    opts = dict(ik=("q",), matrices=("M", "K_F"), model="flexible", status=True)
    want = ev.kernels.fused(x, y, z, by_matrix, **opts)
    got = ev.kernels.fused(x, y, z, by_vector, **opts)
    assert (got["status"] == want["status"]).all() and (want["status"][[5, 17, 66, 79]] == 0).all()
    for key in ("q", "M", "K_F", "freq_hz"):
        scale = np.abs(want[key]).max(axis=tuple(range(1, want[key].ndim)), keepdims=True)
        assert np.all(np.abs(got[key] - want[key]) <= 1e-13 * scale), key


@compiled
def test_an_array_default_takes_the_general_route(monkeypatch):
    """A parameter whose default is an array (a value per pose) cannot be packed once: no
    prepared pass, the general route's answer; a scalar default is prepared."""
    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    fast, general = (eigentwist.load("heli4", backend="c", threads=1) for _ in range(2))
    monkeypatch.setattr(general.c_route, "plan", lambda *args: None)
    poses = random_poses(fast.robot, 4, seed=48)
    m_e = fast.parameters["m_e"]
    for ev in (fast, general):
        monkeypatch.setitem(ev.parameters, "m_e", m_e.with_values(default=np.full(4, m_e.default)))
    got, want = fast.modes(poses, "rigid", vectors=False), general.modes(poses, "rigid", vectors=False)
    assert fast.c_route.plan("rigid", {}, "raise", "raise", False) is None
    assert got.freq_hz.tobytes() == want.freq_hz.tobytes()
    scalar = eigentwist.load("heli4", backend="c", threads=1)
    assert scalar.c_route.plan("rigid", {}, "raise", "raise", False) is not None
    assert scalar.modes(poses, "rigid", vectors=False).freq_hz.tobytes() == got.freq_hz.tobytes()


@compiled
@pytest.mark.parametrize("robot", ["heli4", "hexapod"])
def test_a_short_block_gives_the_padded_full_blocks_bits(robot, monkeypatch):
    """The C pass's loops over a last block of m < 64 poses run over m rounded up to a
    multiple of 8 (the block padded with copies of its last pose): a batch of 1, 7, 8 (a
    multiple), 9 (just past one), 63 or 65 poses gives, bit for bit, the frequencies,
    eigentwists and matrices of its poses in a batch padded to whole blocks of 64 with copies
    of its last pose (the same block mates: the Jacobi sweeps of a block run until all its
    poses converge)."""
    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    ev = eigentwist.load(robot, backend="c", threads=1)
    poses = random_poses(ev.robot, 200, seed=49)
    poses = poses[ev.valid(poses, "paper")][:70]
    p = ev.parameter_values(1, "paper")

    def matrices(P):
        return ev.kernels.fused(P[:, 0], P[:, 1], P[:, 2], {**p, **ev.kernel_pose_inputs(P)}, matrices=("M", "K_F"))

    for m in (1, 7, 8, 9, 63, 65):
        P = poses[:m]
        padded = np.vstack([P, np.repeat(P[-1:], -m % 64, axis=0)])
        got, want = ev.modes(P, "paper"), ev.modes(padded, "paper")
        assert got.freq_hz.tobytes() == want.freq_hz[:m].tobytes(), m
        assert got.eigentwists.tobytes() == want.eigentwists[:m].tobytes(), m
        got, want = matrices(P), matrices(padded)
        assert all(got[k].tobytes() == want[k][:m].tobytes() for k in ("M", "K_F")), m


def test_newest_kept_drops_the_oldest():
    from eigentwist.runtime.memo import NewestKept

    kept = NewestKept(2)
    for k in range(3):
        kept.put(k, k)
    assert list(kept) == [1, 2]  # the oldest dropped, the newest two kept
    kept.put(1, "again")  # put again: the newest now
    kept.put(3, 3)
    assert list(kept) == [1, 3] and kept[1] == "again"
