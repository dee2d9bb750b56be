"""The parallel screen of the C pass's results (eigentwist.runtime.c_route.above_screen)."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime.c_route import PARALLEL_SCREEN, above_screen


def test_the_screen_is_the_rows_lowest_against_their_highest():
    rng = np.random.default_rng(3)
    freq = rng.uniform(1.0, 100.0, (500, 6))
    freq[::7, rng.integers(0, 6)] = 1e-4  # some rows with a mode far below the others
    want = np.array([row.min() > PARALLEL_SCREEN * row.max() for row in freq])
    assert 0 < want.sum() < len(freq)
    np.testing.assert_array_equal(above_screen(freq), want)


def test_the_screen_on_threads_equals_one_pass():
    """Past one chunk the rows are screened in chunks side by side: the same answer, row for
    row (rows below the screen and NaN rows in every chunk)."""
    from eigentwist.runtime.completion import CHUNK

    rng = np.random.default_rng(4)
    freq = rng.uniform(1.0, 100.0, (2 * CHUNK + 123, 6))
    freq[::11, 0] = 1e-4
    freq[::13, 3] = np.nan
    one = above_screen(freq)
    assert 0 < one.sum() < len(freq)
    np.testing.assert_array_equal(above_screen(freq, threads=2), one)
    np.testing.assert_array_equal(above_screen(freq[: CHUNK - 5], threads=2), one[: CHUNK - 5])


def test_either_side_of_the_screen_and_nan_in_any_column():
    row = np.array([1.0, 5.0, 20.0, 50.0, 70.0, 100.0])
    inside, outside = row.copy(), row.copy()
    inside[0], outside[0] = PARALLEL_SCREEN * 100.0 * 1.001, PARALLEL_SCREEN * 100.0 * 0.999
    freq = np.array([row, inside, outside] + [np.where(np.arange(6) == j, np.nan, row) for j in range(6)])
    assert above_screen(freq).tolist() == [True, True, False] + [False] * 6
    assert above_screen(np.array([[3.0]])).tolist() == [True]  # one mode: its own highest
    assert PARALLEL_SCREEN * 1000.0 == 1.0 and above_screen(np.array([[1.0, 1000.0]])).tolist() == [False]  # on it
    assert above_screen(np.empty((0, 6))).shape == (0,)


def test_no_warning_where_a_row_holds_nan():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert above_screen(np.array([[np.nan, 1.0], [1.0, np.inf]])).tolist() == [False, False]


def _exact_checks_counted(monkeypatch) -> list:
    """The batch sizes the prepared pass sends on to the exact check (``CPassRoute.modes``,
    stood in for: its answer is the pass's frequencies), appended to the list returned."""
    from eigentwist.runtime.c_route import CPassRoute
    from eigentwist.runtime.evaluator import AXES, Modes

    checked = []

    def fused_modes(self, arr, *args, **kw):
        checked.append(len(arr))
        return Modes(kw["out"]["freq_hz"], None, AXES, "flexible", None, np.ones(len(arr), dtype=bool))

    monkeypatch.setattr(CPassRoute, "modes", fused_modes)
    return checked


def _fake_pass(freq: np.ndarray, status: np.ndarray, block: int = 64):
    """A prepared pass (:class:`~eigentwist.runtime.fused_call.FusedCall`) whose C function is
    a stand-in writing the rows of ``freq`` (Hz) and ``status`` asked for, and recording the
    ranges it was called on: (the pass, the list of its (begin, end) calls)."""
    import ctypes

    from eigentwist.runtime.fused_call import FusedCall

    P, dim = ctypes.c_void_p, freq.shape[1]
    ranges = []

    def fn(begin, end, ins, strides, model, ik, mat, jac, freq_at, vec, status_at, opts):
        ranges.append((begin, end))
        f = np.ctypeslib.as_array(ctypes.cast(freq_at, ctypes.POINTER(ctypes.c_double)), (end, dim))
        s = np.ctypeslib.as_array(ctypes.cast(status_at, ctypes.POINTER(ctypes.c_int8)), (end,))
        f[begin:end], s[begin:end] = freq[begin:end], status[begin:end]
        return 0

    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ctypes.c_int64, P, P, ctypes.c_int, *[P] * 7)
    names = ["x", "y", "z"]
    call = FusedCall(
        proto(fn), names, {}, {k: 3 for k in names}, model_id=0, dim=dim, vectors=False, matrices=(0, ()),
        options=lambda: (ctypes.c_double * 4)(), block=block, check=lambda rc, what: None,
    )  # fmt: skip
    return call, ranges


def _scheduler_built():
    """The compiled tier (skips without a compiler, fails where CI requires it): the C
    scheduler must then be built (a None would run every "C" case by ranges)."""
    from eigentwist.runtime import c_schedule

    from .conftest import compiled_tier

    compiled_tier().undo()
    assert c_schedule.scheduler() is not None


@pytest.fixture(params=["C", "ranges"])
def schedule(request, monkeypatch):
    """Either way of running a prepared pass: its blocks handed out in C
    (:mod:`eigentwist.runtime.c_schedule`; skipped without a compiler) or by ranges from Python."""
    from eigentwist.runtime import c_schedule

    if request.param == "C":
        _scheduler_built()
    else:
        monkeypatch.setattr(c_schedule, "scheduler", lambda: None)
    return request.param


@pytest.mark.parametrize(
    "lowest, sent",
    [(0.99 * PARALLEL_SCREEN, True), (1.01 * PARALLEL_SCREEN, False)],
)
def test_the_prepared_pass_sends_a_pose_below_the_screen_to_the_exact_check(monkeypatch, schedule, lowest, sent):
    """The prepared C pass's result goes on to the exact check where a pose's lowest
    frequency lies below the screen times its highest (not its second highest: here 0.5)."""
    import eigentwist
    from eigentwist.runtime.evaluator import AXES

    ev = eigentwist.load("heli4", backend="numpy")
    freq = np.array([[3.0, 4.0, 5.0, 6.0, 7.0, 8.0], [lowest, 0.2, 0.3, 0.4, 0.5, 1.0]])
    checked = _exact_checks_counted(monkeypatch)
    call, _ = _fake_pass(freq, np.zeros(2, dtype=np.int8))
    plan = (call, 3, ("actuator_loss",), {}, "flexible", AXES, True, False, "nan")
    modes = ev.c_route.planned_modes(plan, np.zeros((2, 3)))
    assert checked == ([2] if sent else []) and np.array_equal(modes.freq_hz, freq)
    ev.c_route.planned_modes(plan, np.zeros((1, 3)))  # the first row alone: above the screen
    assert checked == ([2] if sent else [])


@pytest.mark.parametrize("threads", [1, 2])
def test_a_long_prepared_batch_is_checked_in_every_part(monkeypatch, schedule, threads):
    """Past one block, range or grain of poses (checked side by side on the threads): a pose
    below the screen, with a NaN highest frequency or flagged by the pass in the last part sends the batch to the
    exact check, and a pose that is not finite anywhere sends it back to ``Evaluator.modes``
    (None)."""
    import eigentwist
    from eigentwist.runtime.c_schedule import GRAIN_BLOCKS
    from eigentwist.runtime.completion import CHUNK
    from eigentwist.runtime.evaluator import AXES

    ev = eigentwist.load("heli4", backend="numpy", threads=threads)
    n = max(CHUNK, 64 * GRAIN_BLOCKS * 20) + 50
    freq = np.tile(np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0]), (n, 1))
    status = np.zeros(n, dtype=np.int8)
    checked = _exact_checks_counted(monkeypatch)
    plan = (_fake_pass(freq, status)[0], 3, ("actuator_loss",), {}, "flexible", AXES, True, False, "nan")
    poses = np.zeros((n, 3))
    ev.c_route.planned_modes(plan, poses)
    assert checked == []  # every pose clean: the pass's answer
    freq[n - 2, 0] = 0.5 * PARALLEL_SCREEN * freq[n - 2, -1]
    ev.c_route.planned_modes(plan, poses)
    assert checked == [n]
    freq[n - 2, 0] = 3.0
    freq[n - 1, -1] = np.nan  # a NaN compares False
    ev.c_route.planned_modes(plan, poses)
    assert checked == [n, n]
    freq[n - 1, -1] = 8.0
    status[n - 1] = 1
    ev.c_route.planned_modes(plan, poses)
    assert checked == [n, n, n]
    for row, col in ((0, 0), (n // 2, 1), (n - 1, 2)):
        bad = poses.copy()
        bad[row, col] = np.inf if row else np.nan
        assert ev.c_route.planned_modes(plan, bad) is None
    assert checked == [n, n, n]


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_the_scheduled_grains_cover_the_batch_once_on_block_boundaries(threads):
    """The C scheduler's grains: every pose in exactly one call of the pass, each call
    GRAIN_BLOCKS blocks (the last one shorter), beginning on a block boundary."""
    from eigentwist.runtime.c_schedule import GRAIN_BLOCKS

    _scheduler_built()
    block = 64
    for n in (1, block, block * GRAIN_BLOCKS, block * GRAIN_BLOCKS + 1, 37 * block * GRAIN_BLOCKS + 5):
        freq = np.tile(np.array([3.0, 4.0]), (n, 1))
        call, ranges = _fake_pass(freq, np.zeros(n, dtype=np.int8), block)
        poses = np.zeros((n, 3))
        at = poses.ctypes.data
        out, clean = call.screened([at + 8 * k for k in range(3)], poses, threads, 0.5)
        got = sorted(ranges)
        assert clean and np.array_equal(out["freq_hz"], freq)
        assert got[0][0] == 0 and got[-1][1] == n and all(a[1] == b[0] for a, b in zip(got, got[1:]))
        assert all(a % block == 0 and b - a == min(block * GRAIN_BLOCKS, n - a) for a, b in got)


def test_the_scheduler_stops_at_a_failing_grain_and_reports_its_code():
    """A nonzero return code of the pass stops the scheduler and reaches the pass's check
    (which raises); on one thread the grains after it are not run."""
    import ctypes

    from eigentwist.runtime.c_schedule import GRAIN_BLOCKS
    from eigentwist.runtime.fused_call import FusedCall

    _scheduler_built()
    span, calls, seen = 64 * GRAIN_BLOCKS, [], []

    def fn(begin, *rest):
        calls.append(begin)
        return -2 if begin == 2 * span else 0

    P = ctypes.c_void_p
    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ctypes.c_int64, P, P, ctypes.c_int, *[P] * 7)
    call = FusedCall(
        proto(fn), ["x"], {}, {"x": 1}, model_id=0, dim=1, vectors=False, matrices=(0, ()),
        options=lambda: (ctypes.c_double * 4)(), block=64, check=lambda rc, what: seen.append(rc),
    )  # fmt: skip
    poses = np.zeros((10 * span, 1))
    call.screened([poses.ctypes.data], poses, 1, 0.5)
    assert seen == [-2] and calls == [0, span, 2 * span]


@pytest.mark.parametrize("screen, clean", [(0.39, True), (0.41, False)])
def test_the_screen_asked_for_decides_clean(schedule, screen, clean):
    """The prepared call's screen is its argument (not the route's default), either way of
    running it: every pose's lowest frequency 0.4 times its highest is clean below a screen
    of 0.4 and not above it."""
    n = 64 * 12 + 5
    freq = np.tile(np.array([4.0, 10.0]), (n, 1))
    call, _ = _fake_pass(freq, np.zeros(n, dtype=np.int8))
    poses = np.zeros((n, 3))
    out, got = call.screened([poses.ctypes.data + 8 * k for k in range(3)], poses, 2, screen)
    assert got is clean and np.array_equal(out["freq_hz"], freq)


@pytest.mark.parametrize("way", ["screened", "unchecked"])
def test_a_failing_grain_reaches_the_pass_check_named(schedule, way):
    """The first nonzero code of the pass reaches the prepared call's check with the pass's
    name, scheduled in C or by ranges, through the screened call and the unchecked one
    (``FusedCall.__call__``: the raw pass of ``benchmarks/public_path.py``)."""
    import ctypes

    from eigentwist.runtime.fused_call import FusedCall

    seen = []

    def fn(begin, end, *rest):
        return -2 if end > 640 else 0  # a later grain fails, or the one call over every pose

    P = ctypes.c_void_p
    proto = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int64, ctypes.c_int64, P, P, ctypes.c_int, *[P] * 7)
    call = FusedCall(
        proto(fn), ["x"], {}, {"x": 1}, model_id=0, dim=1, vectors=False, matrices=(0, ()),
        options=lambda: (ctypes.c_double * 4)(), block=64, check=lambda rc, what: seen.append((rc, what)),
    )  # fmt: skip
    poses = np.zeros((64 * 40, 1))
    if way == "screened":
        call.screened([poses.ctypes.data], poses, 1, 0.5)
    else:
        call([poses.ctypes.data], len(poses), 1)
    assert (-2, "fused") in seen and all(what == "fused" for _, what in seen)


@pytest.mark.compiled
def test_the_unchecked_prepared_call_gives_the_screened_calls_bits(compiled, monkeypatch):
    """``FusedCall.__call__`` (no finite check, no screen) on a robot's prepared pass: the
    outputs of the screened call bit for bit, scheduled in C on two threads and by ranges."""
    import eigentwist
    from eigentwist.runtime import c_schedule

    from .conftest import random_poses

    ev = eigentwist.load("hexapod", backend="c", threads=2)
    call, columns = ev.c_route.plan("none", {}, "raise", "nan", True)[:2]
    poses = random_poses(ev.robot, 64 * c_schedule.GRAIN_BLOCKS * 6 + 3, seed=49)
    poses = np.ascontiguousarray(poses[ev.valid(poses, "none")])
    at = [poses.ctypes.data + 8 * k for k in range(columns)]
    screened, _ = call.screened(at, poses, 2, PARALLEL_SCREEN)
    assert len(poses) > 64 * c_schedule.GRAIN_BLOCKS * 2 and {"freq_hz", "status", "eigentwists"} <= set(screened)
    ways = [call(at, len(poses), 2)]
    monkeypatch.setattr(c_schedule, "scheduler", lambda: None)
    ways.append(call(at, len(poses), 2))
    for got in ways:
        assert sorted(got) == sorted(screened)
        assert all(got[k].tobytes() == screened[k].tobytes() for k in got)


def test_valid_screens_the_parallel_check_with_the_pass_frequencies(monkeypatch):
    """``checks.valid`` with the pass's frequencies sends only the reachable poses below the
    screen to the exact parallel check; without them, every reachable pose."""
    import eigentwist
    from eigentwist.runtime.checks import PoseChecks
    from eigentwist.runtime.validity import STATUS

    ev = eigentwist.load("heli4", backend="numpy")
    sent = []

    def parallel_ok(self, poses, p, rows, strict):
        sent.append(rows.tolist())
        return np.zeros(len(rows), dtype=bool)

    monkeypatch.setattr(PoseChecks, "parallel_ok", parallel_ok)
    freq = np.array([[3.0, 4.0, 5.0], [0.99 * PARALLEL_SCREEN, 0.5, 1.0], [1.01 * PARALLEL_SCREEN, 0.5, 1.0]] * 2)
    status = np.array([STATUS["ok"]] * 3 + [STATUS["unreachable"], STATUS["singular"], STATUS["unstable"]], np.int8)
    poses = np.zeros((6, 3))
    ok = ev.checks.valid(poses, {}, status, freq)
    assert sent == [[1]] and ok.tolist() == [True, False, True, False, False, True]
    sent.clear()
    ok = ev.checks.valid(poses, {}, status)
    assert sent == [[0, 1, 2, 5]] and ok.tolist() == [False] * 6


@pytest.mark.compiled
def test_the_screen_model_is_the_c_routes(compiled):
    """The model whose frequencies screen ``valid``'s parallel check: the C route's own
    (flexible, or rigid where the pass reduces it), none where that route does not take it."""
    import eigentwist

    heli4 = eigentwist.load("heli4", backend="c")
    assert heli4.c_route.pass_model("paper") == "flexible" and heli4.c_route.pass_model("none") == "rigid"
    assert heli4.c_route.pass_model("paper+gravity_preload") is None
    assert eigentwist.load("heli4", backend="numpy").c_route.pass_model("none") is None
    prs3 = eigentwist.load("examples/robots/prs3.py", backend="c", progress=None)
    assert not prs3.c_route.pass_rigid and prs3.c_route.pass_model("none") is None


@pytest.mark.compiled
def test_valid_finds_a_parallel_singular_pose_through_the_screen(compiled):
    """A Delta pose on its parallel singularity (the exact check's conditioning minimised
    from a nearby pose): ``valid`` on the C pass, which screens with the frequencies, says
    what the exact check on every pose says, there and around it."""
    from scipy.optimize import minimize

    import eigentwist
    from eigentwist.runtime.validity import CONDITIONING_TOL

    ev = eigentwist.load("delta", backend="c", threads=1)

    def conditioning(x):
        c = ev.pose_status(np.atleast_2d(x), "none")["conditioning"][0]
        return c if np.isfinite(c) else 1.0

    start = np.array([-0.47868, -0.59388, -0.50101])  # conditioning ~2e-5
    x = minimize(conditioning, start, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-14}).x
    assert conditioning(x) <= CONDITIONING_TOL
    poses = x + np.random.default_rng(5).normal(scale=[[0.0]] + [[1e-3]] * 40 + [[3e-2]] * 40, size=(81, 3))
    poses = np.concatenate([poses, np.random.default_rng(6).uniform(-0.5, 0.5, (200, 3)) + [0, 0, -0.6]])
    completed, p = ev.completion.poses(poses, {}), ev.resolver.resolve(len(poses), {}, "none")
    exact = ev.checks.valid(completed, p, ev.c_route.run(completed, p, matrices=())["status"])
    assert not exact[0] and exact.sum() > 100
    np.testing.assert_array_equal(ev.valid(poses, "none"), exact)
