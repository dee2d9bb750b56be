"""The numerical IK's rules on made-up closures (no robot: cheap): legs solved independently,
the polish to round-off, the warm start from the previous pose (three passes, never the first
pose), the branch's signs, and the homotopy per leg. Expectations follow from the closures'
closed-form solutions written here.
"""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime import levenberg_marquardt as lm

EPS = np.finfo(float).eps
# two legs, three coordinates, four closure rows (consistent: least squares exact)
A = np.random.default_rng(11).normal(size=(2, 4, 3))
C = np.array([[1.0, -0.5, 0.25], [0.3, 0.2, -0.1]])


def _targets(p):
    """(n, legs, 3) the solution: x c_leg + L + off_leg (L a scalar, off one value per leg)."""
    x = np.asarray(p["x"], float).reshape(-1, 1, 1)
    return x * C + p["L"] + np.asarray(p["off"]).reshape(1, 2, 1)


def linear(q, p):
    gap = q - _targets(p)
    return {
        "residual": np.einsum("lrq,nlq->nlr", A, gap),
        "dresidual": np.broadcast_to(A, q.shape[:1] + A.shape).copy(),
    }


def _p(x):
    return {"x": np.asarray(x, float), "L": 0.2, "off": np.array([0.1, -0.3])}


@pytest.mark.parametrize("n", [1, 5, 70])
def test_every_leg_of_every_pose_solved_and_polished_to_round_off(n):
    """n = 70 is past SOA_MIN systems (the entry-by-entry solver); the undamped polish
    leaves the residual at round-off, not at the damped iterations' 1e-12."""
    x = np.linspace(-0.4, 0.5, n)
    p = _p(x)
    q = lm.solve(linear, np.zeros((2, 3)), p, n)
    assert q.shape == (n, 2, 3)
    assert np.abs(q - _targets(p)).max() <= 64 * EPS


def test_a_leg_that_cannot_close_is_nan_and_its_neighbours_are_not():
    def closure(q, p):
        out = linear(q, p)
        x = np.broadcast_to(p["x"], q.shape[:1])
        out["residual"][x == 0.2, 1] += 1.0  # pose 3, leg 2: an offset no coordinate can remove
        return out

    p = _p([-0.4, -0.1, 0.2, 0.5])
    q = lm.solve(closure, np.zeros((2, 3)), p, 4)
    bad = np.zeros((4, 2), bool)
    bad[2, 1] = True
    assert np.isnan(q[bad]).all() and np.abs(q[~bad] - _targets(p)[~bad]).max() <= 64 * EPS


def _one(q, p):
    t = np.asarray(p["t"], float).reshape(-1, 1, 1)
    return {"residual": q - t, "dresidual": np.ones(q.shape + (1,))}


def _alone(t, iterations):
    return np.isfinite(lm.solve(_one, np.zeros((1, 1)), {"t": np.array([t])}, 1, iterations=iterations)).all()


def test_warm_start_from_the_previous_pose_three_passes():
    """With 6 iterations a target 1.0 away from the start converges and 1.5 does not (each
    coordinate moves at most MAX_STEP = 0.25 per iteration). Targets 1, 2, 3, 4, 5 from 0:
    the first from the reference, each next from its predecessor's solution, one pass each:
    three passes reach the fourth, the fifth stays NaN."""
    assert _alone(1.0, 6) and not _alone(1.5, 6)
    q = lm.solve(_one, np.zeros((1, 1)), {"t": np.array([1.0, 2.0, 3.0, 4.0, 5.0])}, 5, iterations=6)
    assert np.abs(q[:4, 0, 0] - [1.0, 2.0, 3.0, 4.0]).max() < 1e-12 and np.isnan(q[4]).all()


def test_the_first_pose_is_never_warm_started():
    """Pose 1 converges next to pose 0's target, but pose 0 does not start from it."""
    q = lm.solve(_one, np.zeros((1, 1)), {"t": np.array([3.0, 0.5, 2.9])}, 3, iterations=6)
    assert np.isnan(q[0]).all() and abs(q[1, 0, 0] - 0.5) < 1e-12 and np.isnan(q[2]).all()


def test_a_failed_pose_does_not_warm_start_the_next():
    q = lm.solve(_one, np.zeros((1, 1)), {"t": np.array([0.5, 3.0, 3.5])}, 3, iterations=6)
    assert abs(q[0, 0, 0] - 0.5) < 1e-12 and np.isnan(q[1:]).all()


def _circle(q, p):
    """One coordinate on a circle of radius 1 around the target: r = q^2 - 1 (solutions +-1)."""
    return {"residual": q**2 - 1.0, "dresidual": (2 * q)[..., None]}


def test_the_branch_signs_given_or_the_references():
    ref = np.array([[0.8], [-0.8]])  # two legs: one on each branch
    p = {"x": np.zeros(2)}
    q, off = lm.solve(_circle, ref, p, 2, branch=lambda q: q[..., 0], report=True)
    assert q[:, :, 0].tolist() == [[1.0, -1.0], [1.0, -1.0]] and not off.any()
    # signs recorded elsewhere (both +): the second leg's solution lies on the other branch
    q, off = lm.solve(_circle, ref, p, 2, branch=lambda q: q[..., 0], signs=[1.0, 1.0], report=True)
    assert off.tolist() == [[False, True], [False, True]]
    assert q[:, 0, 0].tolist() == [1.0, 1.0] and np.isnan(q[:, 1]).all()
    # a reference sign 0 (a singular reference) names no branch: nothing rejected
    q, off = lm.solve(_circle, ref, p, 2, branch=lambda q: q[..., 0], signs=[0.0, 1.0], report=True)
    assert off.tolist() == [[False, True], [False, True]]
    q = lm.solve(_circle, np.array([[0.8], [0.0]]), p, 2, branch=lambda q: q[..., 0])
    assert np.isfinite(q[:, 0]).all()


def test_the_homotopy_per_leg_and_in_one_step():
    p = {"x": np.zeros(1), "L": 0.2, "off": np.array([0.1, -0.3])}
    q, res = lm.continuation(linear, np.zeros((2, 3)), p)
    assert q.shape == (2, 3) and res.shape == (2,)
    assert np.abs(q - _targets(p)[0]).max() < 1e-12 and (res < 1e-12).all()
    q, res = lm.continuation(linear, np.zeros((2, 3)), p, steps=1)
    assert np.abs(q - _targets(p)[0]).max() < 1e-12


def test_the_homotopy_loses_only_the_leg_whose_path_fails():
    f = 1.1 * lm.PATH_TOL / np.sqrt(2)

    def closure(q, p):
        r = np.concatenate([q - 0.4, q - 0.4 - np.array([[2 * f], [0.0]])], axis=-1)  # leg 1's rows disagree
        return {"residual": r, "dresidual": np.ones(q.shape[:-1] + (2, 1))}

    q, res = lm.continuation(closure, np.array([[1.3], [1.3]]), {})
    assert np.isnan(q[0]).all() and abs(q[1, 0] - 0.4) < 1e-12
    assert np.isnan(res[0]) and res[1] < 1e-12


def test_the_homotopy_leaves_a_leg_without_a_finite_reference_residual():
    def closure(q, p):
        r = np.concatenate([q - 0.4, q - 0.4], axis=-1)
        r[:, 0] = np.where(np.abs(q[:, 0] - 1.3) < 1e-15, np.nan, r[:, 0])  # leg 1 not finite at its reference
        return {"residual": r, "dresidual": np.ones(q.shape[:-1] + (2, 1))}

    q, _ = lm.continuation(closure, np.array([[1.3], [1.3]]), {})
    assert np.isnan(q[0]).all() and abs(q[1, 0] - 0.4) < 1e-12


def test_the_homotopy_at_a_singular_jacobian_is_nan():
    def closure(q, p):
        return {"residual": q - 0.4, "dresidual": np.zeros(q.shape + (1,))}

    q, _ = lm.continuation(closure, np.array([[1.3]]), {})
    assert np.isnan(q).all()


def test_same_configuration_of_several_legs():
    a = np.zeros((2, 3))
    b = a.copy()
    b[1, 2] = 2 * lm.BRANCH_GAP
    assert lm.same_configuration(a, b, np.array([True, True, False])).tolist() == [True, False]
    assert lm.same_configuration(np.array([1, 2]), np.array([1, 2]), False).tolist() is True  # integers too


def test_the_homotopy_at_dependent_columns_is_nan():
    """r = q1 + q2 - 0.4: A^T A = [[1, 1], [1, 1]] is singular even with its 1e-300 shift."""

    def closure(q, p):
        return {"residual": q.sum(-1, keepdims=True) - 0.4, "dresidual": np.ones(q.shape[:-1] + (1, 2))}

    q, _ = lm.continuation(closure, np.array([[1.3, 0.2]]), {})
    assert np.isnan(q).all()


def test_two_poses_warm_started_and_one_converging_later():
    q = lm.solve(_one, np.zeros((1, 1)), {"t": np.array([1.0, 2.0])}, 2, iterations=6)
    assert np.abs(q[:, 0, 0] - [1.0, 2.0]).max() < 1e-12
    q = lm.solve(_one, np.zeros((1, 1)), {"t": np.array([0.1, 3.0])}, 2)  # the second needs more iterations alone
    assert np.abs(q[:, 0, 0] - [0.1, 3.0]).max() < 1e-12


@pytest.mark.parametrize("systems", [1, 64])
def test_a_damping_that_is_not_finite_takes_the_gradient_step(systems):
    """H not finite (an infinite damping) with A^T r finite: the step is -A^T r, by either solver."""
    A = np.random.default_rng(2).normal(size=(systems, 4, 3))
    r = np.random.default_rng(3).normal(size=(systems, 4))
    scale = np.ones(systems)
    scale[0] = np.inf
    step = lm.normal_solve(A, r, scale, 0.0)
    assert np.allclose(step[0], -A[0].T @ r[0], rtol=1e-14)
    if systems > 1:
        assert np.isfinite(step[1:]).all()


def test_a_singular_normal_matrix_takes_the_least_squares_step():
    """A = [1, 1], r = 1, no damping: A^T A is singular; the minimum-norm step is -(0.5, 0.5)."""
    step = lm.normal_solve(np.ones((1, 1, 2)), np.ones((1, 1)), 0.0, 0.0)
    assert np.allclose(step, [[-0.5, -0.5]], rtol=1e-14)


def test_no_floating_point_warning_leaves_the_solver():
    def closure(q, p):
        out = linear(q, p)
        x = np.broadcast_to(p["x"], q.shape[:1])
        out["residual"][x == 0.2, 1] = np.nan  # a leg whose closure is not finite
        return out

    with np.errstate(all="raise"):
        q = lm.solve(closure, np.zeros((2, 3)), _p([-0.4, 0.2, 0.5]), 3)
        lm.continuation(closure, np.zeros((2, 3)), _p([0.2]))
    assert np.isnan(q[1, 1]).all() and np.isfinite(q[[0, 2]]).all()


def test_a_solution_past_a_singularity_of_the_branch_is_rejected():
    """The branch's determinant q - 0.9 vanishes between the reference 0.8 and the solution 1:
    the solution lies on another assembly branch (NaN, reported); without a branch nothing is
    reported."""
    q, off = lm.solve(_circle, np.array([[0.8]]), {}, 1, branch=lambda q: q[..., 0] - 0.9, report=True)
    assert np.isnan(q).all() and off.tolist() == [[True]]
    q, off = lm.solve(_circle, np.array([[0.8]]), {}, 1, report=True)
    assert q.tolist() == [[[1.0]]] and off.dtype == bool and off.tolist() == [[False]]


class _Counted:
    """A closure of one leg and coordinate counting its evaluations: r = (q - c)^power."""

    def __init__(self, c, power):
        self.c, self.power, self.calls = c, power, 0

    def __call__(self, q, p):
        self.calls += 1
        gap = q - self.c
        return {"residual": gap**self.power, "dresidual": (self.power * gap ** (self.power - 1))[..., None]}


@pytest.mark.parametrize(
    ("start_r", "calls"),
    [(5e-9, 2), (5e-8, 3)],
    ids=["below EARLY: the undamped step at once", "above EARLY: a damped step first"],
)
def test_below_early_a_leg_takes_the_undamped_step_at_once(start_r, calls):
    """A linear closure (Newton exact in one step) started with |r| below EARLY = 1e-8 (but far
    above TOL) is evaluated twice (the start, the undamped step); above it a damped step comes
    first (three). Either way the leg closes to round-off. (1e-8: quadratic convergence takes
    it below TOL = 1e-12 in one step for a curvature up to 1e4 per unit; on the 6-RUS a tenth
    of it costs 0.16 passes a block more, ten times it saves 0.03: benchmarks/README.md.)"""
    assert lm.EARLY == 1e-8
    closure = _Counted(0.3, 1)
    q, norm = lm._iterate(closure, np.full((1, 1, 1), 0.3 + start_r), {}, lm.MAX_ITERATIONS, lm.TOL, 1e-8)
    assert closure.calls == calls
    assert norm[0, 0] <= 2 * EPS and abs(q[0, 0, 0] - 0.3) <= 2 * EPS


def test_an_undamped_step_that_leaves_the_leg_above_tol_hands_it_back_to_the_damped_steps():
    """r = (q - c)^3: Newton only divides the gap by 3/2 a step (a triple root), so the
    undamped step from |r| below EARLY leaves it above TOL; the damped steps resume and close
    the leg below TOL (then the last undamped step)."""
    closure = _Counted(0.1, 3)
    start = 0.1 + (0.5 * lm.EARLY) ** (1 / 3)
    q, norm = lm._iterate(closure, np.full((1, 1, 1), start), {}, lm.MAX_ITERATIONS, lm.TOL, 1e-8)
    assert norm[0, 0] < lm.TOL
    # the gap shrinks by 2/3 a step: at least log(TOL / r0) / log(8/27) steps past the first
    assert closure.calls >= 2 + int(np.log(lm.TOL / (0.5 * lm.EARLY)) / np.log(8 / 27))
    # with no damped steps left after the first stage, the leg stays where the undamped step left it
    closure = _Counted(0.1, 3)
    _, norm = lm._iterate(closure, np.full((1, 1, 1), start), {}, 0, lm.TOL, 1e-8)
    assert lm.TOL < norm[0, 0] < 0.5 * lm.EARLY and closure.calls == 2


def test_a_step_that_raises_the_residual_is_rejected_and_the_damping_quadrupled():
    """r = q beyond a wall at q = 0.05 (r = 10 before it, where the solution q = 0 lies): from
    q = 0.2 a damped step lands in the wall until the damping keeps it short. Each rejected
    trial leaves q where it was and multiplies lambda by 4, so the trial points are
    q - q / (1 + lambda0 4^k + 1e-12 lambda0 4^k) (the damped step of a = 1) for k = 0, 1, ...,
    the first one past the wall (1 + lambda > 4 / 3: k = 5 from 1e-3) accepted, lambda then
    divided by 4 for the next."""
    seen = []

    def wall(q, p):
        seen.append(float(q[0, 0, 0]))
        r = np.where(q > 0.05, q, 10.0)
        return {"residual": r, "dresidual": np.ones(q.shape + (1,))}

    q0, lam0 = 0.2, 1e-3
    lm._iterate(wall, np.full((1, 1, 1), q0), {}, 7, lm.TOL, lam0)
    lam = lam0 * 4.0 ** np.arange(6)
    want = [q0 - q0 / ((1 + lam_k) + 1e-12 * lam_k) for lam_k in lam]
    # the solver rounds the step's few operations in its own order: a few ulp of q0 (2.8e-17)
    # in the trial point, which cancels most of q0; a factor 5 for 4 moves it by ~1e-5
    assert seen[0] == q0 and seen[1:7] == pytest.approx(want, rel=0, abs=1e-15)
    assert all(t <= 0.05 for t in seen[1:6]) and seen[6] > 0.05  # five rejected, the sixth kept
    q1, lam1 = seen[6], lam[5] / 4
    assert seen[7] == pytest.approx(q1 - q1 / ((1 + lam1) + 1e-12 * lam1), rel=0, abs=1e-15)


def test_the_predicted_start_is_the_closures_tangent_at_the_reference():
    """Two legs whose closed configuration is q = (sin x0 + x1^2, x0 x1) and (x1, -x0) (rows
    r = q - q(x)): the prediction's G is dq/dx at x_ref to the central differences' error (h =
    1e-6: truncation ~1e-13, rounding ~1e-10),
    the prediction at x_ref is q_ref itself and near it first-order accurate (error O(|dx|^2))."""

    def closed(x):
        x0, x1 = x[..., 0], x[..., 1]
        return np.stack([np.stack([np.sin(x0) + x1**2, x0 * x1], -1), np.stack([x1, -x0], -1)], -2)

    def closure(q, p):
        r = q - closed(np.stack([p["x0"], p["x1"]], -1))
        return {"residual": r, "dresidual": np.broadcast_to(np.eye(2), q.shape + (2,)).copy()}

    def inputs_at(x):
        return {"x0": x[:, 0], "x1": x[:, 1]}

    x_ref = np.array([0.3, -0.7])
    q_ref = closed(x_ref)
    pred = lm.predicted_start(closure, q_ref, inputs_at, x_ref)
    c0, x1, x0 = np.cos(x_ref[0]), x_ref[1], x_ref[0]
    dq_dx = np.array([[[c0, 2 * x1], [x1, x0]], [[0.0, 1.0], [-1.0, 0.0]]])  # (legs, n_q, d)
    assert pred.G.T.reshape(2, 2, 2) == pytest.approx(dq_dx, abs=1e-9)
    assert np.array_equal(pred(x_ref[None])[0], q_ref)
    for step in (1e-2, 1e-3):
        x = x_ref + step * np.array([[1.0, -2.0]])
        assert np.abs(pred(x)[0] - closed(x[0])).max() <= 5 * step**2


def test_a_legs_iterations_do_not_depend_on_the_other_legs_of_its_pose():
    """Legs are solved independently: a leg that waits (|r| below EARLY while its neighbour
    steps) and is then handed back to the damped steps (a triple root: the undamped step leaves
    it above TOL) ends bit for bit where it ends alone, its damping its own."""

    def pair(q, p):
        gap = q - np.array([0.1, 0.4])[None, :, None]
        r = np.concatenate([gap[:, :1] ** 3, 2.0 * gap[:, 1:]], axis=1)
        d = np.concatenate([3.0 * gap[:, :1] ** 2, np.full_like(gap[:, 1:], 2.0)], axis=1)
        return {"residual": r, "dresidual": d[..., None]}

    start = 0.1 + (0.5 * lm.EARLY) ** (1 / 3)
    q, norm = lm._iterate(pair, np.array([[[start], [0.9]]]), {}, lm.MAX_ITERATIONS, lm.TOL, 1e-3)
    alone = _Counted(0.1, 3)
    q1, norm1 = lm._iterate(alone, np.full((1, 1, 1), start), {}, lm.MAX_ITERATIONS, lm.TOL, 1e-3)
    assert q[0, 0, 0] == q1[0, 0, 0] and norm[0, 0] == norm1[0, 0] < lm.TOL
    assert abs(q[0, 1, 0] - 0.4) <= 4 * EPS  # the neighbour (a linear leg far off) closed too
