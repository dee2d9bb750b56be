"""The hand-written C helpers of the threaded passes, built afresh: the scheduler of a pass's
blocks (:mod:`eigentwist.runtime.c_schedule`) and the rotation entries (:mod:`eigentwist.runtime.c_poses`).

Each module builds its library once per process and remembers the bound function (or None
where no compiler builds it, and the callers then take their Python or NumPy way, with the
same results). These tests forget what the module remembered, so the build and the binding
run here: where a compiler exists the library must build and its function be bound as its C
declaration says (a helper that silently fell back would pass every test of its results).
Compiled tier: without a compiler they skip, and fail where CI requires the tier.
"""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime import c_poses, c_schedule

from .c_signatures import check

pytestmark = pytest.mark.compiled


def test_the_scheduler_builds_binds_as_declared_and_hands_out_every_block(compiled, monkeypatch):
    from .test_parallel_screen import _fake_pass

    monkeypatch.setattr(c_schedule, "_SCHEDULER", [])
    fn = c_schedule.scheduler()
    assert fn is not None and c_schedule._SCHEDULER == [fn] and c_schedule.scheduler() is fn
    check(c_schedule.SOURCE, "et_schedule_work", fn.argtypes, fn.restype)
    n = 64 * c_schedule.GRAIN_BLOCKS * 3 + 5
    freq = np.tile(np.array([3.0, 4.0]), (n, 1))
    freq[7, 0] = 0.0  # one pose below the screen
    call, ranges = _fake_pass(freq, np.zeros(n, dtype=np.int8))
    poses = np.zeros((n, 3))
    out, clean = call.screened([poses.ctypes.data + 8 * k for k in range(3)], poses, 2, 0.5)
    assert not clean and np.array_equal(out["freq_hz"], freq)
    assert sum(b - a for a, b in ranges) == n and len(ranges) == -(-n // (64 * c_schedule.GRAIN_BLOCKS))


def test_the_rotation_entries_build_bind_as_declared_and_are_numpys(compiled, monkeypatch):
    from eigentwist.runtime.poses import rotation_entries

    monkeypatch.setattr(c_poses, "_FN", [])
    fn = c_poses._function()
    assert fn is not None and c_poses._FN == [fn] and c_poses._function() is fn
    check(c_poses.SOURCE, "et_rotation_entries", fn.argtypes, fn.restype)
    poses = np.zeros((3, 6))
    poses[:, 3:] = [[0.0, 0.0, np.pi / 2], [0.3, -0.2, 0.1], [0.0, 0.0, 0.0]]
    got = c_poses.rotation_entries(poses)
    assert got is not None
    assert np.abs(np.array(got) - np.array(rotation_entries(poses[:, 3:]))).max() <= 4 * np.finfo(float).eps
    np.testing.assert_allclose(np.array(got)[:, 0], [0, -1, 0, 1, 0, 0, 0, 0, 1], atol=1e-15)  # 90 deg about z


def test_the_c_poses_reads_any_number_type_as_its_double_value(compiled):
    """Integer and single-precision poses: the entries of their float64 values (the C function
    reads doubles, so other types are converted first)."""
    rng = np.random.default_rng(4)
    ints = rng.integers(-3, 4, (50, 6))
    want = np.array(c_poses.rotation_entries(ints.astype(np.float64)))
    assert np.array(c_poses.rotation_entries(ints)).tobytes() == want.tobytes()
    singles = rng.uniform(-1, 1, (50, 6)).astype(np.float32)
    want = np.array(c_poses.rotation_entries(singles.astype(np.float64)))
    assert np.array(c_poses.rotation_entries(singles)).tobytes() == want.tobytes()
    assert (
        np.array(c_poses.rotation_entries(ints.tolist())).tobytes()
        == np.array(c_poses.rotation_entries(ints.astype(float))).tobytes()
    )


def test_numeric_iks_batch_driver_binds_as_declared_and_is_taken(compiled, monkeypatch):
    """``et_newton_branch_work`` of the Newton library, bound afresh, and the batch solver a
    numeric-IK robot's C kernels give (the long way, the fallback, gives the same bits, so a
    driver that silently failed to bind would pass the tests of results)."""
    import eigentwist
    from eigentwist.runtime import c_levenberg_marquardt as lm

    from .descriptions import hexapod_urdf

    monkeypatch.setattr(lm, "_BRANCH", [])
    fn = lm.branch_driver()
    assert fn is not None and lm._BRANCH == [fn] and lm.branch_driver() is fn
    check(lm.SOURCE, "et_newton_branch_work", fn.argtypes, fn.restype)
    ev = eigentwist.load(hexapod_urdf.describe(), backend="c", threads=1, progress=lambda m: None)
    whole = ev.completion.closure_inputs(np.array([ev.robot.x_ref]), ev.parameter_values(1))
    solver = ev.kernels.branch_solver(whole, 1, ev.completion.assembly()["sign"])
    assert isinstance(solver, lm.BranchSolver)
