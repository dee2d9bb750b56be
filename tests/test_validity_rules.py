"""The pose checks of ``runtime/validity.py`` on hand-made arrays (no model: cheap): every
threshold on both sides, each leg and row located, the platform rows and their conditioning
against NumPy's QR and SVD, the messages naming pose, unit, leg and value.
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.runtime import validity as v
from eigentwist.runtime.errors import SingularPoseError, UnreachablePoseError

LEGS = [NS(name="leg 1"), NS(name="leg 2"), NS(name="leg 3")]
POSES3 = [[0.0, 0.0, -0.5], [0.1, 0.0, -0.5]]
INT_POSES = [[0, 0, 1], [0, 1, 0, 0, 0, 2]]  # whole numbers are written as floats
POSES6 = [[0.0, 0.0, -0.5, 0.0, 0.0, 0.0], [0.1, 0.0, -0.5, 0.0, 0.0, 0.25]]
TOL = v.CONDITIONING_TOL


# ---------------------------------------------------------------- IK checks and levers
def test_ik_arguments_of_magnitude_one_are_reachable_and_beyond_or_nan_are_not():
    ok = np.array([[1.0, -1.0, 0.5]])
    for bad in (math.nextafter(1.0, 2.0), -math.nextafter(1.0, 2.0), math.nan):
        ik = {"q": np.zeros((2, 3, 2)), "sin_q3": np.vstack([ok, [[0.0, bad, 0.0]]])}
        assert v.reachable_mask(ik).tolist() == [True, False]


def test_every_check_and_the_joint_coordinates_count():
    q = np.zeros((3, 3, 2))
    q[0, 2, 1] = np.nan
    ik = {"q": q, "cos_q2": np.zeros((3, 3)), "sin_q3": np.zeros((3, 3)), "mine": np.zeros((3, 3))}
    ik["cos_q2"][1, 0] = 2.0
    ik["mine"][2, 1] = -3.0
    assert v.reachable_mask(ik).tolist() == [False, False, False]
    ik["mine"][2, 1] = 0.0
    assert v.reachable_mask(ik).tolist() == [False, False, True]


def test_check_names_put_the_known_ones_first_and_leave_out_q():
    assert v.check_names({"zeta": 0, "q": 0, "cos_q2": 0, "sin_q3": 0}) == ["sin_q3", "cos_q2", "zeta"]
    assert v.check_meaning("cos_q2") == v.IK_CHECKS["cos_q2"]
    assert v.check_meaning("zeta") == "the leg's check 'zeta' left [-1, 1]"


def test_a_lever_must_exceed_lever_tol_on_every_leg():
    lever = np.full((3, 3), 0.5)
    lever[1, 2] = v.LEVER_TOL  # exactly the tolerance: singular
    lever[2, 0] = -math.nextafter(v.LEVER_TOL, 1.0)  # just above, either sign
    assert v.lever_mask(lever).tolist() == [True, False, True]


def test_the_unreachable_pose_is_named_with_its_leg_check_and_value():
    ik = {"q": np.zeros((2, 3, 2)), "sin_q3": np.zeros((2, 3)), "cos_q2": np.zeros((2, 3))}
    ik["cos_q2"][1, 1] = 1.25
    ik["cos_q2"][1, 2] = 3.0  # a later leg of the same pose: not the one named
    with pytest.raises(UnreachablePoseError) as e:
        v.raise_unreachable(LEGS, POSES3, ik)
    assert str(e.value) == (
        "pose [0.1, 0.0, -0.5] m is unreachable for leg 2: the lower link and parallelogram cannot span that "
        "distance (cos_q2 = 1.25, expected within [-1, 1])"
    )
    ik = {"sin_q3": np.zeros((2, 3))}
    ik["sin_q3"][1, 0] = np.nan
    with pytest.raises(
        UnreachablePoseError, match=r"^pose \[0.0, 1.0, 0.0, 0.0, 0.0, 2.0\] \(m, rad\) is unreachable for leg 1"
    ):
        v.raise_unreachable(LEGS, INT_POSES, ik)
    v.raise_unreachable(LEGS, POSES3, {"q": np.zeros((2, 3, 2)), "sin_q3": np.ones((2, 3))})  # nothing to say
    v.raise_unreachable(LEGS, POSES3, {"sin_q3": np.ones((2, 3))})  # no joint coordinates: the checks only


def test_a_pose_without_finite_joint_coordinates_is_named_with_its_leg():
    q = np.zeros((2, 3, 2))
    q[1, 2, 1] = np.inf
    q[1, 1, 0] = 0.0
    with pytest.raises(UnreachablePoseError) as e:
        v.raise_unreachable(LEGS, POSES6, {"q": q, "sin_q3": np.zeros((2, 3))})
    assert str(e.value) == (
        "pose [0.1, 0.0, -0.5, 0.0, 0.0, 0.25] (m, rad) is unreachable for leg 3: its inverse kinematics gives "
        "no finite joint coordinates (expected a pose the leg can span)"
    )
    q3 = np.zeros((2, 3, 2, 2))  # joint coordinates with more axes: any non-finite entry
    q3[0, 0, 1, 1] = np.nan
    with pytest.raises(UnreachablePoseError, match=r"^pose \[0.0, 0.0, 1.0\] m is unreachable for leg 1: its"):
        v.raise_unreachable(LEGS, INT_POSES, {"q": q3})


@pytest.mark.parametrize(
    "scale, what", [("l1", "w_a1.t_a1/l1"), (None, "w_a.t_a (the leg's unit twists are dependent)")]
)
def test_the_serial_singular_pose_is_named_with_its_leg_and_lever(scale, what):
    lever = np.full((2, 3), 0.5)
    lever[1, 0] = -v.LEVER_TOL
    lever[1, 2] = 0.0
    with pytest.raises(SingularPoseError) as e:
        v.raise_singular(LEGS, POSES6, lever, scale)
    assert str(e.value) == (
        f"pose [0.1, 0.0, -0.5, 0.0, 0.0, 0.25] (m, rad) is serial singular for leg 1: actuation lever {what} "
        "= -0.001 (expected |.| > 0.001)"
    )
    v.raise_singular(LEGS, POSES3, np.full((2, 3), math.nextafter(v.LEVER_TOL, 1.0)))  # just above: nothing


def test_the_serial_singular_message_uses_m_for_a_point():
    with pytest.raises(SingularPoseError, match=r"^pose \[0.0, 0.0, 1.0\] m is serial singular for leg 3: "):
        v.raise_singular(LEGS, INT_POSES, np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))


# ---------------------------------------------------------------- the platform rows
def _leg(name, n_virtual):
    """A leg with one actuated freedom, then a virtual joint of ``n_virtual`` freedoms."""
    joints = [NS(freedoms=1, virtual=False), NS(freedoms=n_virtual, virtual=True)]
    return NS(name=name, joints=joints, kinematics=NS(jacobian_rows=list(range(1 + n_virtual))))


def test_platform_rows_unit_actuation_rows_and_orthonormal_constraint_bases_per_leg():
    rng = np.random.default_rng(3)
    legs = [_leg("a", 2), _leg("b", 1), _leg("c", 3)]
    J = np.zeros((2, 3, 4, 6))
    J[:, 0, :3], J[:, 1, :2], J[:, 2, :4] = (
        rng.normal(size=(2, 3, 6)),
        rng.normal(size=(2, 2, 6)),
        rng.normal(size=(2, 4, 6)),
    )
    J[:, 2, 1] = J[:, 0, 1]  # leg c's first constraint equals leg a's: legs are not orthogonalised together
    W = v.platform_rows(J, legs)
    assert W.shape == (2, 1 + 2 + 1 + 1 + 1 + 3, 6)
    unit = lambda x: x / np.linalg.norm(x, axis=-1, keepdims=True)  # noqa: E731
    for n in range(2):
        blocks = [(0, 0, 2), (1, 3, 1), (2, 5, 3)]  # (leg, first row in W, constraint rows)
        for leg, row, c in blocks:
            assert np.allclose(W[n, row], unit(J[n, leg, 0]), atol=1e-14)  # the actuated row
            B = W[n, row + 1 : row + 1 + c]
            raw = J[n, leg, 1 : 1 + c]
            assert np.allclose(B @ B.T, np.eye(c), atol=1e-13)
            assert np.allclose(B[0], unit(raw[0]), atol=1e-14)  # Gram-Schmidt keeps the first direction
            Q = np.linalg.qr(raw.T)[0]
            assert np.allclose(B.T @ B, Q @ Q.T, atol=1e-12)  # the same span
    assert np.allclose(W[:, 6], W[:, 1], atol=1e-14)


def test_platform_rows_along_a_basis_of_freedoms():
    legs = [_leg("a", 1), _leg("b", 1), _leg("c", 1)]
    J = np.random.default_rng(0).normal(size=(1, 3, 2, 6))
    basis = np.eye(6)[:, 3:]  # the three translations
    W = v.platform_rows(J, legs, basis)
    assert np.allclose(W, v.platform_rows(J, legs)[..., 3:], atol=1e-15)


def test_a_vanishing_row_stays_zero_and_conditions_to_zero():
    legs = [_leg("a", 1)]
    J = np.zeros((1, 1, 2, 2))
    J[0, 0, 1] = [0.0, 3.0]
    W = v.platform_rows(J, legs)
    assert W.tolist() == [[[0.0, 0.0], [0.0, 1.0]]]
    assert v.conditioning(W).tolist() == [0.0]


def test_rotations_are_scaled_by_the_conditioning_length(monkeypatch):
    legs = [_leg("a", 1)]
    J = np.array([[[[2.0, 0, 0, 0, 0, 1.0], [0, 1.0, 0, 1.0, 0, 0]]]])
    monkeypatch.setattr(v, "CONDITIONING_LENGTH", 2.0)  # rows act on [L omega; v], L = 2 m
    W = v.platform_rows(J, legs)
    s = 1 / math.sqrt(2)
    assert np.allclose(W[0], [[s, 0, 0, 0, 0, s], [0, 1 / math.sqrt(1.25) / 2, 0, 1 / math.sqrt(1.25), 0, 0]])


# ---------------------------------------------------------------- conditioning and the parallel check
def _rows(singular_values, d=6, seed=0):
    """(1, r, d) rows with these singular values (random orthogonal factors)."""
    rng = np.random.default_rng(seed)
    s = np.asarray(singular_values, float)
    U = np.linalg.qr(rng.normal(size=(len(s), len(s))))[0]
    V = np.linalg.qr(rng.normal(size=(d, d)))[0]
    return (U @ np.diag(s) @ V[: len(s)])[None]


def test_conditioning_is_the_smallest_over_the_largest_singular_value():
    rows = np.concatenate([_rows([2.0, 1.5, 1.0, 1.0, 0.5, 0.1]), np.full((1, 6, 6), np.nan)])
    out = v.conditioning(rows)
    assert out[0] == pytest.approx(0.05, rel=1e-12) and math.isnan(out[1])
    assert v.conditioning(_rows([1.0] * 5)).tolist() == [0.0]  # five rows cannot fix six twists
    # rank 5 of 6 (this seed's smallest eigenvalue of G comes out -2e-16): 0 to round-off, not NaN
    assert 0.0 <= v.conditioning(_rows([1.0] * 5 + [0.0], seed=4))[0] < 1e-7
    assert v.conditioning(np.full((1, 5, 6), np.nan)).tolist()[0] != 0.0


@pytest.mark.parametrize("factor, ok", [(0.98, False), (1.02, True)])
def test_parallel_mask_on_both_sides_of_the_conditioning_tolerance(factor, ok):
    rows = _rows([2.0, 1.0, 1.0, 1.0, 1.0, 2 * TOL * factor])  # the ratio counts, not the scale
    # the squared singular value carries an error of eps times the largest: relative eps / (2 TOL^2) ~ 5e-5
    assert v.conditioning(rows)[0] == pytest.approx(TOL * factor, rel=1e-3)
    assert v.parallel_mask(rows).tolist() == [ok]


def test_the_determinant_bound_settles_a_fair_pose_without_eigenvalues(monkeypatch):
    """det G / tr(G)^d = 1e-4 / 5.0001^6 ~ 6e-9, above TOL^2 ~ 2e-12: sure without eigvalsh;
    1e-8 / 5^6 ~ 6e-13 is below: the conditioning 1e-4 is computed (and passes)."""
    rows = _rows([1.0] * 5 + [0.01])
    called = []
    eigvalsh = np.linalg.eigvalsh
    monkeypatch.setattr(np.linalg, "eigvalsh", lambda G: called.append(len(G)) or eigvalsh(G))
    assert v.parallel_mask(rows).tolist() == [True] and called == []
    assert v.parallel_mask(_rows([1.0] * 5 + [1e-4])).tolist() == [True] and called == [1]


def test_parallel_mask_rows_that_are_not_finite_or_too_few():
    rows = np.concatenate([_rows([1.0] * 6), _rows([1.0] * 6)])
    rows[1, 2, 3] = np.inf
    assert v.parallel_mask(rows).tolist() == [True, False]
    few = v.parallel_mask(_rows([1.0] * 5))
    assert few.dtype == bool and few.tolist() == [False]


def test_parallel_mask_lets_no_floating_point_warning_out():
    rows = np.concatenate([_rows([1.0] * 6), _rows([1.0] * 6), _rows([1e60] * 6), _rows([1.0] * 6)])
    rows[1, 4] = 0.0  # a vanishing row: conditioning 0
    rows[3, 0, :2] = [np.inf, -np.inf]  # inf - inf in the finite check
    rows[3, 1, :2] = 1e308  # and an overflow
    # rows of 1e60: det G and tr(G)^6 overflow, inf / inf
    with np.errstate(all="raise"):
        assert v.parallel_mask(rows).tolist() == [True, False, True, False]
        assert v.platform_rows(np.full((1, 1, 2, 6), np.inf), [_leg("a", 1)]).shape == (1, 2, 6)


def test_the_parallel_singular_pose_is_named_with_its_conditioning():
    rows = np.concatenate([_rows([1.0] * 6), _rows([1.0] * 5 + [1e-6]), _rows([1.0] * 5 + [0.0])])
    with pytest.raises(SingularPoseError) as e:
        v.raise_parallel(POSES6 + [[0.0] * 6], rows)
    assert str(e.value) == (
        "pose [0.1, 0.0, -0.5, 0.0, 0.0, 0.25] (m, rad) is parallel singular: the legs' actuation and constraint "
        f"wrenches leave a twist of the platform free (conditioning 1e-06, expected above {TOL:.3g})"
    )
    with pytest.raises(SingularPoseError, match=r"^pose \[0.0, 1.0, 0.0, 0.0, 0.0, 2.0\] \(m, rad\) is parallel"):
        v.raise_parallel(INT_POSES, rows[:2])
    with pytest.raises(SingularPoseError, match=r"^pose \[0.1, 0.0, -0.5\] m is parallel singular"):
        v.raise_parallel(POSES3, rows[:2])
    v.raise_parallel(POSES3, rows[:1])  # a fair pose: nothing


def test_a_pose_is_named_in_the_robots_own_coordinates():
    from eigentwist.runtime.validity import pose_text

    six = [0.1, 0.2, 0.3, 0.01, 0.02, 0.03]
    assert pose_text([0.1, 0.2, 0.3]) == "[0.1, 0.2, 0.3] m"
    assert pose_text(six) == "[0.1, 0.2, 0.3, 0.01, 0.02, 0.03] (m, rad)"
    assert pose_text(six, ("x", "y", "z", "rot_x", "rot_y", "rot_z")) == pose_text(six)
    assert pose_text(six, ("x", "y")) == "[0.1, 0.2] m"  # a point in a plane, completed
    assert pose_text([0.1, 0.2, 0.0], ("x", "y")) == "[0.1, 0.2] m"  # its position x, y, z
    assert pose_text([0.1, 0.2], ("x", "y")) == "[0.1, 0.2] m"  # as given
    assert pose_text(six, ("z", "rot_x", "rot_y")) == "[0.3, 0.01, 0.02] (m, rad)"  # a 3-PRS, completed
    assert pose_text(six, ("x", "y", "rot_z")) == "[0.1, 0.2, 0.03] (m, rad)"  # planar


def test_a_point_platforms_refusal_names_its_own_coordinates():
    import eigentwist
    from eigentwist.runtime.errors import UnreachablePoseError

    five_bar = eigentwist.load("examples/robots/five_bar.py", backend="numpy", progress=None)
    with pytest.raises(UnreachablePoseError, match=r"^pose \[0\.0, 0\.9\] m is unreachable for leg 1: "):
        five_bar.frequencies([0.0, 0.9], "none")
