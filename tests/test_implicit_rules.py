"""Derivatives through solved coordinates (``runtime/implicit.py``) on a made-up evaluator whose
loop closure and matrices are polynomials: the implicit-function derivatives and the total
derivatives along the solution path are written out by hand here (no model derived: cheap).

The closure of each leg is ``A q - A h(p, pose)`` with ``A`` (3 rows, 2 coordinates: least
squares, consistent), so ``q = h`` and ``dq/dp = dh/dp``. Parameter ``a`` is far from its lower
bound (central differences), ``b`` sits on it (one-sided, second order); both are exact up to
round-off for the quadratics used, and the matrices' paths are quartic (truncation h^2 ~ 1e-10).
"""

from __future__ import annotations

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from eigentwist.runtime import implicit
from eigentwist.runtime.sensitivity import DIFFERENCE_STEP

A = np.array([[[1.0, 0.5], [0.0, 2.0], [1.0, -1.0]], [[2.0, 0.0], [0.3, 1.0], [0.0, 1.0]]])  # (legs, rows, n_q)
E = [np.diag(np.arange(1.0, 7.0)), np.eye(6)[::-1] + np.eye(6), np.ones((6, 6)) + 5 * np.eye(6)]
POSES = np.array([[0.1, 0.2, -0.5], [-0.3, 0.4, -0.6]])
DEFAULTS = {"a": 2.0, "b": 0.5}


def _h(p, poses):
    """(N, legs, 2) the closure's solution: q[:, leg] = (a x (leg + 1), b^2 + a y leg)."""
    a, b = np.broadcast_to(p["a"], (len(poses),)), np.broadcast_to(p["b"], (len(poses),))
    x, y = poses[:, 0], poses[:, 1]
    return np.stack([np.stack([a * x * (leg + 1), b**2 + a * y * leg], axis=-1) for leg in range(2)], axis=1)


def _dh(p, poses):
    """(N, legs, 2, [a, b]) by hand."""
    x, y = poses[:, 0], poses[:, 1]
    b = np.broadcast_to(p["b"], (len(poses),))
    out = np.zeros((len(poses), 2, 2, 2))
    for leg in range(2):
        out[:, leg, 0, 0], out[:, leg, 1, 0] = x * (leg + 1), y * leg
        out[:, leg, 1, 1] = 2 * b
    return out


def _matrices(q, p):
    """M, K_R, K_F: polynomials of q and p times fixed 6x6 patterns."""
    a, b = (np.asarray(p[k], float)[:, None, None] for k in ("a", "b"))
    s = [1 + q[:, 0, 0, None, None] ** 2 + a, b * q[:, 1, 1, None, None], a * b + q[:, 0, 1, None, None]]
    return {k: s[i] * E[i] for i, k in enumerate(("M", "K_R", "K_F"))}


def _total(q, dq, p):
    """dM, dK_R, dK_F (N, [a, b], 6, 6): chain rule through q(p), written out."""
    a, b = (np.asarray(p[k], float) for k in ("a", "b"))
    ds = [
        [2 * q[:, 0, 0] * dq[:, 0, 0, 0] + 1, 2 * q[:, 0, 0] * dq[:, 0, 0, 1]],
        [b * dq[:, 1, 1, 0], q[:, 1, 1] + b * dq[:, 1, 1, 1]],
        [b + dq[:, 0, 1, 0], a + dq[:, 0, 1, 1]],
    ]
    return {
        k: np.stack([ds[i][j][:, None, None] * E[i] for j in range(2)], axis=1)
        for i, k in enumerate(("M", "K_R", "K_F"))
    }


class Ev:
    defaults = DEFAULTS
    parameters = {"a": NS(bounds=(0.0, math.inf)), "b": NS(bounds=(0.5, 1.0))}

    def __init__(self):
        self.models, self.checked, self.values, self.matrix_a = [], [], [], []
        self.kernels = NS(loop_closure=self._closure, matrices=self._kernel_matrices)

    def parameter_values(self, n, model, **params):
        self.models.append(model)
        self.values.append({k: np.asarray(params.get(k, v), float) for k, v in DEFAULTS.items()})
        return {k: np.broadcast_to(np.asarray(params.get(k, v), float), (n,)).copy() for k, v in DEFAULTS.items()}

    def joint_angles(self, poses, **params):
        assert poses is POSES
        self.checked.append(dict(params))

    def pose_inputs(self, poses):
        return {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}

    def closure_inputs(self, poses, p):
        return {**p, **self.pose_inputs(poses)}

    def solve_joints(self, poses, p):
        return _h(p, poses)

    def _closure(self, q, inputs):
        poses = np.stack([inputs["x"], inputs["y"], inputs["z"]], axis=1)
        h = _h(inputs, poses)
        return {
            "residual": np.einsum("lrq,nlq->nlr", A, q - h),
            "dresidual": np.broadcast_to(A, (len(q),) + A.shape),
        }

    def _kernel_matrices(self, q, inputs):
        assert np.array_equal(inputs["x"], POSES[:, 0])
        self.matrix_a.append(float(np.min(inputs["a"])))
        return _matrices(q, inputs)

    def stiffness(self, given, model="paper", **params):
        self.models.append(model)
        p = self.parameter_values(len(given), "paper", **params)
        a, b = p["a"][:, None, None], p["b"][:, None, None]
        x = np.asarray(given)[:, 0, None, None]
        return (a**2 + x) * E[0][:3, :3], (b**3 * x + a * b) * E[1][:3, :3]


def test_steps_are_central_unless_the_lower_bound_is_within_one_step():
    ev = Ev()
    steps = implicit.difference_steps(ev, ["a", "b", "b@2"], {"b@2": 0.5 + 2e-5 * 1.01, "a": 3.0})
    assert [(n, float(v), central) for n, v, _, central in steps] == [
        ("a", 3.0, True),
        ("b", 0.5, False),  # on its bound
        ("b@2", 0.5 + 2.02e-5, True),  # a leg's own value, just over one step (1e-5 x 0.5...) above it
    ]
    assert [float(h) for _, _, h, _ in steps] == pytest.approx([3e-5, 5e-6, DIFFERENCE_STEP * (0.5 + 2.02e-5)])
    near = implicit.difference_steps(ev, ["b"], {"b": 0.5 + 5e-6 * 0.99})[0]
    assert near[3] is False  # within one step of the bound: one-sided


@pytest.mark.parametrize("central", [True, False])
def test_differences_are_exact_for_a_quadratic(central):
    def f(pp):
        c = float(pp["c"])
        return {"v": np.array([[c**2, 3 * c - 5.0]])}

    at0 = {"v": np.array([[4.0, 1.0]])}  # f at c = 2 (read by the one-sided difference)
    d = implicit._difference(f, "c", 2.0, np.array(1e-3), central, {"c": 2.0}, at0)
    assert d["v"] == pytest.approx(np.array([[4.0, 3.0]]), rel=1e-9)

    def g(pp):
        return np.reshape(pp["c"], (-1, 1)) ** 2 * np.ones((2, 3))

    arr = implicit._difference(g, "c", 2.0, np.array([1e-3, 2e-3]), central, {"c": 2.0}, 4.0 * np.ones((2, 3)))
    assert arr == pytest.approx(4.0 * np.ones((2, 3)), rel=1e-9)  # a step per row broadcasts over the trailing axes


def test_joint_derivatives_by_the_implicit_function_theorem():
    ev = Ev()
    q, dq = implicit.joint_derivatives(ev, POSES, ["a", "b"], {})
    p = dict(DEFAULTS)
    assert np.array_equal(q, _h(p, POSES))
    assert dq == pytest.approx(_dh(p, POSES), rel=1e-7, abs=1e-9)
    assert ev.checked == [{}]  # the pose checked once (one line for a bad pose)
    assert set(ev.models) == {"paper"}
    _never_below_b_bound_and_central_in_a(ev)


def _never_below_b_bound_and_central_in_a(ev):
    """b sits on its lower bound: never evaluated below it; a is stepped to either side."""
    assert min(float(np.min(v["b"])) for v in ev.values) == 0.5
    assert min(float(np.min(v["a"])) for v in ev.values) < DEFAULTS["a"] < max(float(np.max(v["a"])) for v in ev.values)


def test_a_one_sided_parameter_first():
    ev = Ev()
    q, dq = implicit.joint_derivatives(ev, POSES, ["b", "a"], {})
    assert dq == pytest.approx(_dh(DEFAULTS, POSES)[..., ::-1], rel=1e-7, abs=1e-9)


def test_joint_derivatives_at_other_values():
    ev = Ev()
    params = {"a": 1.5, "b": 0.75}  # b off its bound: central
    q, dq = implicit.joint_derivatives(ev, POSES, ["b", "a"], params)
    assert ev.checked == [params]
    assert dq == pytest.approx(_dh(params, POSES)[..., ::-1], rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("params", [{}, {"a": 1.5, "b": 0.75}, {"a": np.array([1.5, 2.5])}])
def test_matrix_derivatives_along_the_solution_path(params):
    """At the defaults, elsewhere, and with a value per pose (a step per pose)."""
    ev = Ev()
    out = implicit.numeric_matrix_derivatives(ev, POSES, ["a", "b"], "flexible", params)
    p = {**DEFAULTS, **params}
    q, dq = _h(p, POSES), _dh(p, POSES)
    p = {k: np.broadcast_to(v, (2,)) for k, v in p.items()}
    for k, v in _matrices(q, p).items():
        assert out[k] == pytest.approx(v, rel=1e-12)
    for k, v in _total(q, dq, p).items():
        assert out["d" + k] == pytest.approx(v, rel=1e-6, abs=1e-8)
    assert "flexible" in ev.models  # the matrices of the model asked for
    if not params:
        _never_below_b_bound_and_central_in_a(ev)
        assert min(ev.matrix_a) < DEFAULTS["a"]  # the matrices' difference in a is central too


@pytest.mark.parametrize("params", [{}, {"a": 1.5, "b": 0.75}])
def test_reduced_derivatives_of_the_pencil(params):
    ev = Ev()
    given = POSES
    out = implicit.reduced_derivatives(ev, given, ["a", "b"], "rigid", params)
    a, b = ({**DEFAULTS, **params}[k] for k in ("a", "b"))
    x = given[:, 0, None, None]
    assert out["M"] == pytest.approx((a**2 + x) * E[0][:3, :3])
    assert out["K"] == pytest.approx((b**3 * x + a * b) * E[1][:3, :3])
    dM = np.stack([2 * a * E[0][:3, :3] + 0 * x, 0 * x * E[0][:3, :3]], axis=1)
    dK = np.stack([b * E[1][:3, :3] + 0 * x, (3 * b**2 * x + a) * E[1][:3, :3]], axis=1)
    assert out["dM"] == pytest.approx(dM, rel=1e-6, abs=1e-9) and out["dK"] == pytest.approx(dK, rel=1e-6, abs=1e-9)
    assert set(ev.models) == {"rigid", "paper"}
    assert ev.models.count("rigid") == 1 + 2 * 2  # the pencil, then two per parameter
    if not params:
        _never_below_b_bound_and_central_in_a(ev)


# -- followers that move with the parameters ----------------------------------------------------------------------
class Full(np.ndarray):
    """The stand-in's completed poses (taken as complete when given back)."""


GIVEN = np.array([[0.5, 0.2, -0.1], [0.0, 0.0, 0.3]])  # commanded (z, rot_x, rot_y); row 1: no follower moves


class FollowerEv:
    """A lower-mobility stand-in: followers x = 1000 (a - 1.5) z^2 + z / 10 and y = b^2 rot_x
    (rot_z = 0); M, K_R, K_F cubic in the completed pose and linear in a and m. At a = 1.5, x is
    small and moves fast with a: a pose step longer than POSE_STEP shows in the cubic term."""

    defaults = {"a": 2.0, "b": 0.5, "m": 1.0}
    parameters = {"a": NS(bounds=(0.0, math.inf)), "b": NS(bounds=(0.5, 1.0)), "m": NS(bounds=(0.0, math.inf))}

    def completed_poses(self, given, **pp):
        a, b = (pp.get(k, self.defaults[k]) for k in ("a", "b"))
        z, rx, ry = np.asarray(given, dtype=float).T
        return np.stack([1000 * (a - 1.5) * z**2 + z / 10, b**2 * rx, z, rx, ry, 0 * z], axis=1).view(Full)

    def matrices(self, full, model, **params):
        assert isinstance(full, Full) and model == "flexible model"
        a, m = (params.get(k, self.defaults[k]) for k in ("a", "m"))
        x, y = (np.asarray(full)[:, k, None, None] for k in (0, 1))
        return {"M": (1 + x**3 + m) * E[0], "K_R": (y**3 + 2 * y) * E[1], "K_F": (a * x + x**3 + a * y) * E[2]}


def test_follower_terms_are_the_chain_rule_through_the_followers():
    """``(dX/dx) dx/dp`` written out: a moves x (central differences), b on its lower bound moves
    y (one-sided), m moves none (zero, and the parameters after it still counted); the
    matrices are asked with the caller's values (a = 1.5, not the default)."""
    ev, params = FollowerEv(), {"a": 1.5}
    full = ev.completed_poses(GIVEN, **params)
    got = implicit.follower_terms(ev, GIVEN, full, ("m", "a", "b"), "flexible model", params)
    x, y = np.asarray(full)[:, 0], np.asarray(full)[:, 1]
    z, rx = GIVEN[:, 0], GIVEN[:, 1]
    dx_da, dy_db = 1000 * z**2, 2 * 0.5 * rx

    def pattern(c, k):
        return c[:, None, None] * E[k]

    want = {
        "dM": np.stack([0 * E[0][None].repeat(2, 0), pattern(3 * x**2 * dx_da, 0), 0 * pattern(x, 0)], axis=1),
        "dK_R": np.stack([0 * pattern(x, 1), 0 * pattern(x, 1), pattern((3 * y**2 + 2) * dy_db, 1)], axis=1),
        "dK_F": np.stack([0 * pattern(x, 2), pattern((1.5 + 3 * x**2) * dx_da, 2), pattern(1.5 * dy_db, 2)], axis=1),
    }
    assert set(got) == set(want)
    for k in want:
        np.testing.assert_allclose(got[k], want[k], rtol=1e-7, atol=1e-7 * np.abs(want[k]).max(), err_msg=k)
    assert not got["dK_F"][1].any()  # row 1: no follower moves


def test_follower_terms_without_moving_followers_are_zero():
    ev = FollowerEv()
    got = implicit.follower_terms(ev, GIVEN[1:], ev.completed_poses(GIVEN[1:]), ("a", "b", "m"), "flexible model", {})
    assert all(not v.any() for v in got.values()) and got["dM"].shape == (1, 3, 6, 6)
