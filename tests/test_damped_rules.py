"""The damped modes' solver (:mod:`eigentwist.runtime.damped`) on problems small enough to solve
by hand: a mass on a spring in series with one actuator (its poles: the roots of a cubic written
here from the series impedance), two masses on two legs (a pole makes the dynamic stiffness
``s^2 M + K - sum_i phi_i(s) w_i w_i^T`` singular), and the solver's pieces on made-up
eigenvalues and shares. Every rule's threshold on both sides; the compiled driver's dispatch with a
stand-in of :mod:`.c_damped`. No evaluator, no compile.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from eigentwist.runtime import c_damped
from eigentwist.runtime import damped
from eigentwist.runtime.damped import (
    AMBIGUOUS,
    ELIMINATE,
    NO_POLE,
    RIGID,
    UNSTABLE_ZETA,
    actuator_wrenches,
    coupled_wrenches,
    damped_modes,
    distinct_rows,
)
from eigentwist.runtime.errors import InputError


def series(m, k_s, k_d, c_d, t_d, loss=0.0):
    """A mass m on a passive spring k_s (1 + i loss) in series with the actuator's impedance
    Z(s) = (k_d + c_d s) / (1 + t_d s): m s^2 + 1 / (1/k_s + 1/Z) = 0, multiplied out to
    m (c_d + k_s t_d) s^3 + m (k_d + k_s) s^2 + k_s c_d s + k_s k_d = 0. Returns the inputs of
    :func:`damped_modes` (one pose) and the cubic's roots."""
    ks = k_s * (1 + 1j * loss)
    roots = np.roots([m * (c_d + ks * t_d), m * (k_d + ks), ks * c_d, ks * k_d])
    k0 = ks * k_d / (ks + k_d)  # the undamped series stiffness: K, the actuator wrench w and h
    inputs = dict(
        M=np.full((1, 1, 1), m),
        K=np.full((1, 1, 1), k0.real),
        W=np.full((1, 1, 1), k0 if loss else k0.real),
        h=np.full((1, 1), k0 if loss else k0.real),
        k_d=k_d,
        c_d=c_d,
        t_d=t_d,
        K_loss=np.full((1, 1, 1), k0.imag) if loss else None,
    )
    return inputs, roots


def upper(roots):
    return roots[roots.imag > 0]


@pytest.mark.parametrize("c_d, t_d", [(0.05, 0.0), (0.5, 0.0), (0.2, 1e-3)])
def test_one_mass_in_series_with_an_actuator(c_d, t_d):
    inputs, roots = series(1.5, 100.0, 3.0, c_d, t_d)
    d = damped_modes(**inputs)
    (s,) = upper(roots)
    assert d.poles[0, 0] == pytest.approx(s, rel=1e-12)
    assert d.natural_hz[0, 0] == pytest.approx(abs(s) / (2 * np.pi), rel=1e-12)
    assert d.damped_hz[0, 0] == pytest.approx(s.imag / (2 * np.pi), rel=1e-12)
    assert d.damping_ratio[0, 0] == pytest.approx(-s.real / abs(s), rel=1e-10)
    assert d.shapes is None and d.stable.tolist() == [True]
    # the eigenvectors' route (shapes asked) gives the same pole and the shape 1
    d = damped_modes(**inputs, shapes=True)
    assert d.poles[0, 0] == pytest.approx(s, rel=1e-12)
    assert d.shapes.shape == (1, 1, 1) and d.shapes[0, 0, 0] == pytest.approx(1.0, abs=1e-15)


def test_the_wrenches_of_the_series_chain():
    """actuator_wrenches of one leg of one joint: K = w = h = the series stiffness."""
    k_s, k_d = 100.0, 3.0
    Je = np.ones((1, 1, 1, 1))
    Cq = np.full((1, 1, 1, 1), 1 / k_s + 1 / k_d)
    K, W, h = actuator_wrenches(Je, Cq, np.full((1, 1), 1 / k_d))
    k0 = k_s * k_d / (k_s + k_d)
    assert (K.shape, W.shape, h.shape) == ((1, 1, 1), (1, 1, 1), (1, 1))
    assert K[0, 0, 0] == pytest.approx(k0, rel=1e-14) and W[0, 0, 0] == pytest.approx(k0, rel=1e-14)
    assert h[0, 0] == pytest.approx(k0, rel=1e-14)
    # the loss factor: the passive spring k_s (1 + i eta), the actuator's 1/k_d unchanged
    K, W, h = actuator_wrenches(Je, Cq, np.full((1, 1), 1 / k_d), loss=np.array([0.1]))
    ks = k_s * (1 + 0.1j)
    k0 = ks * k_d / (ks + k_d)
    for v in (K[0, 0, 0], W[0, 0, 0], h[0, 0]):
        assert v == pytest.approx(k0, rel=1e-13)


def test_overdamped_mode_is_its_pair_of_real_poles():
    """c_d between the two limits (the structure's and the servo's): three real roots; the
    mode's pair is the two slow ones (the fast one is the actuator's internal pole near
    -alpha/beta): omega_n^2 = s1 s2, 2 zeta omega_n = -(s1 + s2), no damped frequency."""
    inputs, roots = series(1.0, 100.0, 1.0, 2.0, 0.0)
    assert np.all(np.abs(roots.imag) < 1e-12)
    s1, s2 = sorted(roots.real)[1:]
    for shapes in (False, True):
        d = damped_modes(**inputs, shapes=shapes)
        wn = np.sqrt(s1 * s2)
        assert d.natural_hz[0, 0] == pytest.approx(wn / (2 * np.pi), rel=1e-10)
        assert d.damping_ratio[0, 0] == pytest.approx(-(s1 + s2) / (2 * wn), rel=1e-10)
        assert d.damping_ratio[0, 0] > 1 and d.damped_hz[0, 0] == 0.0
        assert d.poles[0, 0] == pytest.approx(s2, rel=1e-10)  # the slower of the pair
        assert d.stable.tolist() == [True]


def test_loss_factor_counts_only_the_poles_of_positive_frequency():
    """A hysteretic loss: the cubic with k_s (1 + i eta); its root of negative frequency grows
    (the mirror of the decaying one) and is no pole: the pose is stable."""
    inputs, roots = series(1.5, 100.0, 3.0, 0.01, 0.0, loss=0.2)
    s = roots[np.argmin(abs(roots - 1j * np.sqrt(2.9 / 1.5)))]  # the mode, near the undamped omega
    assert s.real < 0 and np.any(roots.real > 1e-4 * abs(roots))
    d = damped_modes(**inputs)
    assert d.poles[0, 0] == pytest.approx(s, rel=1e-10)
    assert d.stable.tolist() == [True]


def test_solver_names():
    inputs, _ = series(1.5, 100.0, 3.0, 0.2, 0.0)
    with pytest.raises(InputError) as err:
        damped_modes(**inputs, solver="C")
    assert str(err.value) == "solver='C': expected 'numpy' or 'c'"


def two_masses(n_poses=1, c_d=(0.3, 0.1), t_d=(0.0, 2e-3)):
    """Two masses (x1, x2) joined by a spring, each held by a leg: a passive spring in series
    with an actuator. Returns the inputs of :func:`damped_modes` and the dynamic stiffness."""
    m = np.array([1.0, 2.0])
    k_s, k_d, k_12 = np.array([200.0, 150.0]), np.array([5.0, 8.0]), 3.0
    k0 = k_s * k_d / (k_s + k_d)
    K = np.diag(k0) + k_12 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    W = np.diag(k0)  # leg i pushes mass i
    c_d, t_d = np.array(c_d), np.array(t_d)

    def dynamic(s):
        Z = (k_d + c_d * s) / (1 + t_d * s)
        legs = 1 / (1 / k_s + 1 / Z)
        return s * s * np.diag(m) + np.diag(legs) + k_12 * np.array([[1.0, -1.0], [-1.0, 1.0]])

    inputs = dict(
        M=np.broadcast_to(np.diag(m), (n_poses, 2, 2)),
        K=np.broadcast_to(K, (n_poses, 2, 2)),
        W=np.broadcast_to(W, (n_poses, 2, 2)),
        h=np.broadcast_to(k0, (n_poses, 2)),
        k_d=k_d,
        c_d=c_d,
        t_d=t_d,
    )
    return inputs, dynamic


def singular(D):
    sv = np.linalg.svd(D, compute_uv=False)
    return sv[-1] / sv[0]


def test_two_masses_poles_make_the_dynamic_stiffness_singular():
    inputs, dynamic = two_masses()
    d = damped_modes(**inputs, shapes=True)
    lam = np.linalg.eigvals(np.linalg.solve(inputs["M"][0], inputs["K"][0]))
    om = np.sqrt(np.sort(lam.real))
    for j in range(2):
        s = d.poles[0, j]
        assert s.imag > 0 and singular(dynamic(s)) < 1e-10
        assert abs(abs(s) - om[j]) < 0.2 * om[j]  # column j: undamped mode j
        x = d.shapes[0, :, j]
        assert x[np.argmax(np.abs(x))] == pytest.approx(1.0, abs=1e-15)
        r = dynamic(s) @ x
        assert np.linalg.norm(r) < 1e-9 * np.linalg.norm(dynamic(s))
    assert d.damping_ratio[0].tolist() == pytest.approx((-d.poles[0].real / abs(d.poles[0])).tolist(), rel=1e-12)


def test_repeated_rows_are_solved_once_and_returned_in_order(monkeypatch):
    """Three poses, the first and the last one condition: one solve of the two distinct rows,
    each row's result in its place (the shapes too)."""
    inputs, dynamic = two_masses(n_poses=3)
    K = np.array(inputs["K"])
    K[1] = K[1] * 1.5  # the middle pose stiffer
    inputs["K"] = K
    calls = []
    eigvals = np.linalg.eig

    def spy(A):
        calls.append(A.shape)
        return eigvals(A)

    monkeypatch.setattr(np.linalg, "eig", spy)
    d = damped_modes(**inputs, shapes=True)
    assert calls == [(2, 6, 6)]  # 2n + legs states, two distinct poses
    middle = {**inputs, "M": inputs["M"][1:2], "K": K[1:2], "W": inputs["W"][1:2], "h": inputs["h"][1:2]}
    alone = damped_modes(**middle)
    assert np.array_equal(d.poles[0], d.poles[2]) and not np.allclose(d.poles[0], d.poles[1])
    assert np.allclose(d.poles[1], alone.poles[0], rtol=1e-13)
    for j in range(2):
        assert singular(dynamic(d.poles[0, j])) < 1e-10
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles", "shapes", "stable"):
        v = getattr(d, name)
        assert len(v) == 3 and np.array_equal(v[0], v[2]), name
    assert np.allclose(d.shapes[1], damped_modes(**middle, shapes=True).shapes[0])


def test_repeated_rows_keep_the_loss_factor_and_couplings_per_row():
    """Rows that differ only in K_loss (or only in G) are distinct: each solved with its own."""
    inputs, _ = series(1.5, 100.0, 3.0, 0.2, 1e-3, loss=0.05)
    two = {k: (np.concatenate([v, v]) if isinstance(v, np.ndarray) else v) for k, v in inputs.items()}
    two["K_loss"] = np.array([[[-2.0]], [[-4.0]]])
    d = damped_modes(**two)
    for k in range(2):
        one = {key: (v[k : k + 1] if isinstance(v, np.ndarray) else v) for key, v in two.items()}
        assert d.poles[k, 0] == pytest.approx(damped_modes(**one).poles[0, 0], rel=1e-13)
    assert d.poles[0, 0] != pytest.approx(d.poles[1, 0], rel=1e-3)


def test_an_unstable_undamped_model_gives_nan_and_is_unstable():
    """A pose whose undamped stiffness is not positive: NaN values, stable False; the other
    pose of the batch solved."""
    inputs, dynamic = two_masses(n_poses=2)
    K = np.array(inputs["K"])
    K[0] = -K[0]
    d = damped_modes(**{**inputs, "K": K}, shapes=True)
    assert d.stable.tolist() == [False, True]
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles", "shapes"):
        v = getattr(d, name)
        assert np.all(np.isnan(v[0])) and not np.any(np.isnan(v[1])), name
    assert singular(dynamic(d.poles[1, 0])) < 1e-10
    d = damped_modes(**{**inputs, "K": K})  # by the eigenvalues' order
    assert d.stable.tolist() == [False, True] and np.all(np.isnan(d.natural_hz[0]))


def one_mode(beta, c_d=1e-3, k_d=1.0):
    """One mode of omega = 2 exactly (M = 1, K = 4), one leg with w = 1, t_d = 0 and h chosen
    for ``beta = c_d (k_d - h)``; alpha = k_d^2, D = -c_d."""
    return dict(
        M=np.ones((1, 1, 1)),
        K=np.full((1, 1, 1), 4.0),
        W=np.ones((1, 1, 1)),
        h=np.array([[k_d - beta / c_d]]),
        k_d=k_d,
        c_d=c_d,
        t_d=0.0,
    )


@pytest.mark.parametrize("shapes", [False, True])
def test_elimination_at_its_bound(monkeypatch, shapes):
    """|beta| omega_max <= ELIMINATE alpha: the leg eliminated (the 2n mechanical states alone);
    one ulp above: its internal coordinate kept (2n + 1 states). k_d = 2: alpha = 4, h = 0."""
    sizes = []
    for name in ("eig", "eigvals"):
        original = getattr(np.linalg, name)
        monkeypatch.setattr(np.linalg, name, lambda A, f=original: sizes.append(A.shape[-1]) or f(A))
    c_at = ELIMINATE  # beta = 2 c_d, beta * 2 == ELIMINATE * 4 exactly
    for c_d, states in ((c_at, 2), (np.nextafter(c_at, 1.0), 3)):
        inputs = one_mode(2 * c_d, c_d=c_d, k_d=2.0)
        assert inputs["h"][0, 0] == 0.0
        sizes.clear()
        d = damped_modes(**inputs, shapes=shapes)
        assert sizes == [states]
        # the eliminated leg: s^2 + (c_d w^2 / k_d^2) s + omega^2 = 0
        exact = upper(np.roots([1.0, c_d / 4.0, 4.0]))[0]
        assert d.poles[0, 0] == pytest.approx(exact, rel=1e-12)


def test_a_leg_with_a_zero_internal_pole_coefficient():
    """beta = 0 (no series compliance along the actuator, c_d > 0): eliminated however small
    omega, its damping term D / alpha; with no leg live the states are the mechanical ones."""
    inputs = one_mode(0.0, c_d=0.5)
    inputs["h"] = np.array([[1.0]])
    d = damped_modes(**inputs)
    exact = upper(np.roots([1.0, 0.5, 4.0]))[0]
    assert d.poles[0, 0] == pytest.approx(exact, rel=1e-12)


def test_unstable_at_its_bound():
    """An eliminated leg of negative damping (D / alpha = -2 zeta omega): zeta = -UNSTABLE_ZETA
    times 2 unstable, times 1/2 stable; the pole's zeta as given."""
    for zeta, stable in ((-2 * UNSTABLE_ZETA, False), (-0.5 * UNSTABLE_ZETA, True)):
        c = 2 * zeta * 2.0  # s^2 + c s + 4: zeta = c / 4
        d = damped_modes(np.ones((1, 1, 1)), np.full((1, 1, 1), 4.0), np.ones((1, 1, 1)), 1.0, 1.0, c, 0.0)
        assert d.damping_ratio[0, 0] == pytest.approx(zeta, rel=1e-6)
        assert d.stable.tolist() == [stable]


def test_the_legs_values_broadcast_per_pose_and_per_leg():
    """k_d, c_d, t_d and h as scalars, per leg (legs,) or per pose and leg (N, legs): the same."""
    inputs, _ = two_masses(n_poses=2)
    full = {k: np.broadcast_to(np.asarray(inputs[k]), (2, 2)).copy() for k in ("k_d", "c_d", "t_d", "h")}
    a = damped_modes(**{**inputs, **full})
    b = damped_modes(**inputs)
    assert np.array_equal(a.poles, b.poles)
    assert damped._legs_array(2.0, 3, 2).shape == (3, 2)
    v = np.ones((3, 2))
    assert damped._legs_array(v, 3, 2) is v


def test_distinct_rows():
    key = np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    first, inverse = distinct_rows(key)
    assert len(first) == 3 and np.array_equal(key[first][inverse], key)
    assert sorted(inverse.tolist()) == [0, 0, 1, 1, 2] and inverse[0] == inverse[2] and inverse[1] == inverse[3]
    assert distinct_rows(key[:2]) == (None, None)  # every row distinct
    nan = np.array([[np.nan, 1.0], [np.nan, 1.0]])
    assert distinct_rows(nan) == (None, None)
    # two different rows of one weighted sum (weights 1, 1.5): not one row
    assert distinct_rows(np.array([[1.5, 0.0], [0.0, 1.0]])) == (None, None)
    first, inverse = distinct_rows(np.array([[0.0, 1.0], [0.0, 1.0]]))
    assert first.tolist() == [0] and inverse.tolist() == [0, 0]


def test_wrenches_of_two_joints_and_a_rigid_direction():
    """Je (1 pose, 1 leg, 2 joints, 3), C_q with its passive joint rigid (compliance RIGID times
    the largest, exactly): K = J^T C^+ J with the rigid direction left out, w = J^T K_q e_0."""
    Je = np.array([[[[1.0, 0.5, 0.0], [0.0, 1.0, 2.0]]]])
    for c, rigid in ((RIGID * 0.5, True), (np.nextafter(RIGID * 0.5, 1.0), False)):
        Cq = np.array([[[[0.5, 0.0], [0.0, c]]]])
        K, W, h = actuator_wrenches(Je, Cq, np.full((1, 1), 0.25))
        Kq = np.diag([2.0, 0.0 if rigid else 1 / c])
        J = Je[0, 0]
        assert np.allclose(K[0], J.T @ Kq @ J, rtol=1e-14, atol=0)
        assert np.allclose(W[0, 0], J.T @ Kq[:, 0], rtol=1e-14) and h[0, 0] == pytest.approx(2.0, rel=1e-14)


def test_rigid_is_relative_to_each_legs_largest_compliance():
    """Two legs, one a thousand times stiffer: its compliances (1e-12) are far below RIGID times
    the other leg's (1) but not its own: both its joints compliant. An exactly zero compliance
    is rigid without a division by zero."""
    Je = np.broadcast_to(np.eye(2), (1, 2, 2, 2))
    Cq = np.array([[np.diag([1.0, 0.0]), np.diag([1e-12, 2e-12])]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        K, W, h = actuator_wrenches(Je, Cq, np.full((1, 2), 0.5))
    assert np.allclose(K[0], np.diag([1.0 + 1e12, 0.5e12]), rtol=1e-14)
    assert h[0].tolist() == pytest.approx([1.0, 1e12], rel=1e-14)


def test_wrenches_of_three_coupled_joints():
    """A full 3x3 compliance (eigenvectors not symmetric): K_q = C^-1."""
    C = np.array([[0.5, 0.1, 0.05], [0.1, 0.3, -0.02], [0.05, -0.02, 0.2]])
    Je = np.array([[[[1.0, 0.0], [0.5, 1.0], [0.0, 2.0]]]])
    K, W, h = actuator_wrenches(Je, C[None, None], np.full((1, 1), 0.1))
    Kq = np.linalg.inv(C)
    assert np.allclose(K[0], Je[0, 0].T @ Kq @ Je[0, 0], rtol=1e-12)
    assert np.allclose(W[0, 0], Je[0, 0].T @ Kq[:, 0], rtol=1e-12) and h[0, 0] == pytest.approx(Kq[0, 0], rel=1e-12)


def test_wrenches_of_coupled_joints():
    """A full 2x2 compliance: K_q = C^-1 (by hand), two legs summed in K."""
    C = np.array([[0.5, 0.1], [0.1, 0.3]])
    Kq = np.array([[0.3, -0.1], [-0.1, 0.5]]) / (0.15 - 0.01)
    Je = np.array([[[[1.0, 0.0], [0.0, 1.0]], [[2.0, 1.0], [0.0, 3.0]]]])
    Cq = np.broadcast_to(C, (1, 2, 2, 2))
    K, W, h = actuator_wrenches(Je, Cq, np.full((1, 2), 0.1))
    want = sum(J.T @ Kq @ J for J in Je[0])
    assert np.allclose(K[0], want, rtol=1e-13)
    assert np.allclose(W[0], [J.T @ Kq[:, 0] for J in Je[0]], rtol=1e-13)
    assert np.allclose(h[0], Kq[0, 0], rtol=1e-13)


def test_wrenches_by_the_driver_where_it_is_built(monkeypatch):
    Je, Cq, a0 = np.ones((1, 1, 1, 1)), np.ones((1, 1, 1, 1)), np.ones((1, 1))
    seen = []
    monkeypatch.setattr(c_damped, "wrenches", lambda *a: seen.append(a) or "from C")
    assert actuator_wrenches(Je, Cq, a0, solver="c") == "from C"
    assert seen[0][1] is Cq and seen[0][2] == RIGID and seen[0][3] is a0 and seen[0][4] is None
    loss = np.array([0.1])
    actuator_wrenches(Je, Cq, a0, loss=loss, solver="c")
    assert seen[1][4] is loss
    assert actuator_wrenches(Je, Cq, a0) != "from C" and len(seen) == 2  # numpy: never asked
    monkeypatch.setattr(c_damped, "wrenches", lambda *a: None)  # not built: NumPy
    K, W, h = actuator_wrenches(Je, Cq, a0, solver="c")
    assert K[0, 0, 0] == 1.0 and W[0, 0, 0] == 1.0 and h[0, 0] == 1.0


def test_coupled_wrenches_condense_the_massless_coordinates():
    """x = [t; theta] with one t and one theta: K = K_tt - K_tc K_cc^-1 K_ct and so on, by hand."""
    K_x = np.array([[[4.0, 1.0], [1.0, 2.0]]])
    W_x = np.array([[[1.0, 3.0], [2.0, -1.0]]])  # two legs
    K, W, G = coupled_wrenches(K_x, W_x, k=1)
    assert K.shape == (1, 1, 1) and K[0, 0, 0] == pytest.approx(4.0 - 1.0 / 2.0, rel=1e-15)
    assert W[0, :, 0].tolist() == pytest.approx([1.0 - 1.0 * 3.0 / 2.0, 2.0 - 1.0 * -1.0 / 2.0], rel=1e-15)
    assert np.allclose(G[0], [[4.5, -1.5], [-1.5, 0.5]], rtol=1e-15, atol=0)
    # two massive coordinates: the condensed stiffness symmetric, by the Schur complement
    rng = np.random.default_rng(2)
    A = rng.normal(size=(1, 4, 4))
    K_x = A @ np.swapaxes(A, -1, -2) + 4 * np.eye(4)
    W_x = rng.normal(size=(1, 3, 4))
    K, W, G = coupled_wrenches(K_x, W_x, k=2)
    inv = np.linalg.inv(K_x[0, 2:, 2:])
    assert np.allclose(K[0], K_x[0, :2, :2] - K_x[0, :2, 2:] @ inv @ K_x[0, 2:, :2], rtol=1e-13)
    assert np.array_equal(K[0], K[0].T)
    assert np.allclose(W[0], W_x[0, :, :2] - W_x[0, :, 2:] @ inv @ K_x[0, 2:, :2], rtol=1e-13)
    assert np.allclose(G[0], W_x[0, :, 2:] @ inv @ W_x[0, :, 2:].T, rtol=1e-13)
    # the round-off asymmetry of the stiffness averaged out: K exactly symmetric
    K_x = np.array([[[4.0, 1.0 + 1e-9, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 2.0]]])
    K, _, _ = coupled_wrenches(K_x, np.ones((1, 1, 3)), k=2)
    assert np.array_equal(K[0], K[0].T) and K[0, 0, 1] == pytest.approx(1.0 + 0.5e-9, rel=1e-15)
    # by default the first six coordinates carry mass (the tool's twist)
    K, W, G = coupled_wrenches(np.broadcast_to(np.eye(8), (1, 8, 8)), np.ones((1, 2, 8)))
    assert K.shape == (1, 6, 6) and W.shape == (1, 2, 6) and np.array_equal(G[0], np.full((2, 2), 2.0))


def test_order_decides_within_ambiguous():
    """_by_order: omega = (1, 2); each pole of positive frequency closer to its mode than
    AMBIGUOUS times the gap (1) decides by order; one at exactly that distance does not."""
    om = np.array([[1.0, 2.0]])
    for d, decided in ((0.5 * AMBIGUOUS, True), (AMBIGUOUS, False)):
        p = np.array([(0.0 if d == AMBIGUOUS else -0.01) + 1j * (1.0 + d), -0.02 + 1.9j])  # |s| - 1 = d exactly
        s = np.concatenate([p, p.conj(), [-5.0]])[None, :]
        got = damped._by_order(s, om, 2)
        if not decided:
            assert got is None
            continue
        s_out, (wn, zeta, wd, poles, cols) = got
        assert s_out is s and cols.tolist() == [[0, 1]]
        assert np.array_equal(poles, p[None, :]) and np.array_equal(wn, np.abs(p)[None, :])
        assert np.allclose(zeta, -p.real / np.abs(p)) and np.array_equal(wd, p.imag[None, :])
    # the poles listed in another order: sorted by |s|
    p = np.array([-0.02 + 1.9j, -0.01 + 1.1j])
    s = np.concatenate([p.conj(), p])[None, :]
    _, (wn, _, _, poles, cols) = damped._by_order(s, om, 2)
    assert cols.tolist() == [[3, 2]] and np.array_equal(poles[0], p[::-1])
    # the lowest mode's pole at the next mode's side beyond AMBIGUOUS times its gap
    s = np.array([[1.1j, 2.6j, -1.1j, -2.6j]])
    assert damped._by_order(s, om, 2) is None
    # one mode's pole overdamped: fewer poles of positive frequency than modes
    assert damped._by_order(np.array([[1.1j, -1.1j, -0.5, -3.0]]), om, 2) is None
    # three modes, the middle one's neighbours on both sides
    om3 = np.array([[1.0, 2.0, 2.2]])
    s = np.array([[1.0j, 2.06j, 2.2j, -1.0j, -2.06j, -2.2j]])  # 0.06 > 0.5 * 0.2 / 2 to the right: not decided
    assert damped._by_order(s, om3, 3) is not None  # |2.06 - 2| = 0.06 < 0.5 * min(1, 0.2) = 0.1
    s = np.array([[1.0j, 2.12j, 2.2j, -1.0j, -2.12j, -2.2j]])
    assert damped._by_order(s, om3, 3) is None  # 0.12 > 0.1


def test_assign_by_share_and_the_overdamped_pair():
    """_assign on made-up poles and modal-energy shares (N = 1, two modes):
    mode 0 takes the pole of positive frequency with its largest share; mode 1 has none left:
    overdamped, its two real poles of largest share."""
    s = np.array([[-0.1 + 1.0j, -0.1 - 1.0j, -1.0 + 0j, -4.0 + 0j, -50.0 + 0j]])
    share = np.array([[[0.5, 0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.4, 0.5, 0.1]]])
    wn, zeta, wd, poles, cols = damped._assign(s, share, 2)
    assert cols[0, 0] == 0 and poles[0, 0] == s[0, 0]
    assert wn[0, 0] == pytest.approx(abs(s[0, 0])) and wd[0, 0] == 1.0
    assert zeta[0, 0] == pytest.approx(0.1 / abs(s[0, 0]))
    assert wn[0, 1] == pytest.approx(2.0) and zeta[0, 1] == pytest.approx(5.0 / 4.0)
    assert wd[0, 1] == 0.0 and poles[0, 1] == -1.0  # the slower of -4 and -1
    # one pole wanted by both modes (argmax): the one-to-one assignment of largest total share
    s = np.array([[-0.1 + 1.0j, -0.1 - 1.0j, -0.2 + 3.0j, -0.2 - 3.0j]])
    share = np.array([[[0.6, 0.0, 0.4, 0.0], [0.7, 0.0, 0.3, 0.0]]])
    wn, zeta, wd, poles, cols = damped._assign(s, share, 2)
    assert cols[0].tolist() == [2, 0]  # 0.4 + 0.7 > 0.6 + 0.3
    assert np.array_equal(poles[0], [s[0, 2], s[0, 0]]) and np.array_equal(wd[0], [3.0, 1.0])
    # one mode: a real pole of larger share loses to the pole of positive frequency, however
    # slow that oscillation (0.5 rad/s); a second pose of its own order
    s = np.array([[-2.0 + 0j, -0.1 + 0.5j, -0.1 - 0.5j, -5.0 + 0j], [-0.1 + 0.5j, -2.0 + 0j, -5.0 + 0j, -0.1 - 0.5j]])
    share = np.array([[[0.6, 0.3, 0.1, 0.0]], [[0.3, 0.6, 0.0, 0.1]]])
    wn, zeta, wd, poles, cols = damped._assign(s, share, 1)
    assert cols.tolist() == [[1], [0]] and np.array_equal(poles[:, 0], [-0.1 + 0.5j, -0.1 + 0.5j])
    assert np.array_equal(wd[:, 0], [0.5, 0.5]) and np.allclose(zeta[:, 0], 0.1 / abs(-0.1 + 0.5j), rtol=1e-15)
    # an overdamped pair slower than 1 rad/s: omega_n^2 = 0.1, 2 zeta omega_n = 0.7
    wn, zeta, wd, poles, _ = damped._assign(np.array([[-0.5 + 0j, -0.2 + 0j]]), np.array([[[0.6, 0.4]]]), 1)
    assert wn[0, 0] == pytest.approx(np.sqrt(0.1), rel=1e-15) and zeta[0, 0] == pytest.approx(0.7 / (2 * np.sqrt(0.1)))


def test_assign_one_leaves_a_mode_without_a_pole_nan():
    """No pole of positive frequency and one real pole for two modes: the first mode takes it,
    the other has none (NaN); a pole beyond NO_POLE is never taken; a share of zero leaves a
    mode to the real poles."""
    s = np.array([-2.0 + 0j, -NO_POLE + 0j])
    share = np.array([[0.2, 0.9], [0.7, 0.05]])
    poles, cols = damped._assign_one(s, share, 2)
    assert poles[0] == -2.0 and cols[0] == 0 and np.isnan(poles[1])
    s = np.array([-0.1 + 1.0j, -0.1 - 1.0j, -3.0 + 0j, -1.0 + 0j])
    share = np.array([[0.0, 0.0, 0.2, 0.8], [0.5, 0.5, 0.0, 0.0]])
    poles, cols = damped._assign_one(s, share, 2)
    assert cols.tolist() == [3, 0] and poles[0] == -1.0 and poles[1] == s[0]
    # the pair of an overdamped mode skips the pole beyond NO_POLE and itself
    s = np.array([-1.0 + 0j, -NO_POLE + 0j, -3.0 + 0j])
    share = np.array([[0.5, 0.9, 0.3]])
    assert damped._pair(s, share, 0, 0) == (-1.0, -3.0)
    s = np.array([-1.0 + 0j, -3.0 + 0j, -7.0 + 0j])
    assert damped._pair(s, np.array([[0.5, 0.1, 0.3]]), 0, 0) == (-1.0, -7.0)  # the next largest share
    # the one-to-one assignment gives a mode a pole in which it has no share: a real pole instead
    s = np.array([-0.1 + 1.0j, -0.1 - 1.0j, -1.0 + 0j])
    poles, cols = damped._assign_one(s, np.array([[0.0, 0.5, 0.5]]), 1)
    assert poles.tolist() == [-1.0] and cols.tolist() == [2]
    # a mode left without any pole: no natural frequency, no damped one
    wn, zeta, wd, poles, _ = damped._assign(np.array([[-2.0 + 0j]]), np.array([[[1.0], [0.5]]]), 2)
    assert poles[0, 0] == -2.0 and np.isnan(wn[0, 1]) and np.isnan(zeta[0, 1]) and wd[0, 1] == 0.0
    assert damped._pair(np.array([-1.0 + 0j, 1j]), np.array([[1.0, 0.0]]), 0, 0) == (-1.0, -1.0)  # alone


def test_an_overdamped_pair_of_a_zero_pole():
    """The pair (0, -3): omega_n 0, zeta 1 (no division by zero)."""
    s = np.array([[0.0 + 0j, -3.0 + 0j]])
    wn, zeta, wd, poles, _ = damped._assign(s, np.array([[[0.6, 0.4]]]), 1)
    assert wn[0, 0] == 0.0 and zeta[0, 0] == 1.0 and wd[0, 0] == 0.0 and poles[0, 0] == 0.0


def test_pencil_poles_beyond_the_limit_and_rows_not_ok():
    """_pencil_eig: A v = s B v with B = I, A = diag(2, 3): s = 2, 3; a limit of exactly 3 keeps
    both, one ulp below it puts 3 at -NO_POLE; a row not ok (A singular) is not solved."""
    A = np.array([np.diag([2.0, 3.0]), np.zeros((2, 2))])
    B = np.broadcast_to(np.eye(2), (2, 2, 2))
    ok = np.array([True, False])
    s, V = damped._pencil_eig(A, B, np.array([3.0, 3.0]), ok)
    assert sorted(s[0].real.tolist()) == [2.0, 3.0]
    s, V = damped._pencil_eig(A, B, np.array([np.nextafter(3.0, 0.0), 3.0]), ok)
    assert sorted(s[0].real.tolist()) == [-NO_POLE, 2.0]
    assert V.shape == (2, 2, 2)


@pytest.mark.parametrize(
    "A",
    [
        np.diag([2.0, 3.0, 1.0]),  # real eigenvalues, one of them 0
        np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),  # complex ones and 0
    ],
)
def test_pencil_of_an_exactly_singular_b_warns_nothing(A):
    """B's zero row: an eigenvalue mu = 0 of A^-1 B exactly, its s = 1/mu infinite (no warning)
    and put at -NO_POLE."""
    B = np.diag([1.0, 1.0, 0.0])[None]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s, _ = damped._pencil_eig(A[None], B, np.array([1e9]), np.array([True]))
    assert np.sum(s[0] == -NO_POLE) == 1 and np.all(np.abs(s[0][s[0] != -NO_POLE]) < 10)


class Driver:
    """A stand-in of :mod:`.c_damped`'s solve and solve_complex: the NumPy solver on each row it
    is given, rows ``undecided`` (of its own input) marked for NumPy with garbage values."""

    def __init__(self, undecided=()):
        self.calls = []
        self.undecided = list(undecided)

    def solve(self, M, K, W, h, k_d, c_d, t_d, eliminate, unstable, ambiguous, threads=1, K_loss=None, entry="solve"):
        self.calls.append(dict(M=M, K=K, W=W, h=h, k_d=k_d, c_d=c_d, t_d=t_d, rules=(eliminate, unstable, ambiguous)))
        self.calls[-1].update(threads=threads, K_loss=K_loss, entry=entry)
        d = damped_modes(M, K, W, h, k_d, c_d, t_d, K_loss=K_loss)
        wn, wd = d.natural_hz * 2 * np.pi, d.damped_hz * 2 * np.pi
        out = [wn, d.damping_ratio, wd, d.poles, d.stable.copy()]
        redo = np.zeros(len(K), dtype=bool)
        redo[[k for k in self.undecided if k < len(K)]] = True
        for v in out:
            v[redo] = 7.0
        return (*out, redo)

    def solve_complex(self, M, K, K_loss, W, h, k_d, c_d, t_d, eliminate, unstable, ambiguous, threads=1):
        return self.solve(M, K, W, h, k_d, c_d, t_d, eliminate, unstable, ambiguous, threads, K_loss, "complex")


@pytest.fixture
def driver(monkeypatch):
    stand_in = Driver(undecided=[1])
    monkeypatch.setattr(c_damped, "driver", lambda: object())
    monkeypatch.setattr(c_damped, "solve", stand_in.solve)
    monkeypatch.setattr(c_damped, "solve_complex", stand_in.solve_complex)
    return stand_in


def test_the_driver_solves_each_distinct_row_once(driver):
    inputs, _ = two_masses(n_poses=4)
    K = np.array(inputs["K"])
    K[1] *= 1.5
    K[3] *= 2.0
    K[2] = K[0]
    inputs["K"] = K
    want = damped_modes(**inputs)
    d = damped_modes(**inputs, solver="c", threads=3)
    (call,) = driver.calls
    assert len(call["K"]) == 3 and call["threads"] == 3 and call["K_loss"] is None and call["entry"] == "solve"
    assert call["rules"] == (ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)
    assert call["k_d"].shape == (3, 2)
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles", "stable"):
        assert np.allclose(getattr(d, name), getattr(want, name), rtol=1e-13), name  # row 1 redone in NumPy
    assert d.shapes is None and d.stable.dtype == bool


def test_the_driver_on_distinct_rows_and_undecided_ones(driver):
    inputs, _ = two_masses(n_poses=3)
    K = np.array(inputs["K"]) * np.array([1.0, 1.5, 2.0])[:, None, None]
    inputs["K"] = K
    d = damped_modes(**inputs, solver="c")
    assert len(driver.calls[0]["K"]) == 3
    want = damped_modes(**inputs)
    assert np.allclose(d.poles, want.poles, rtol=1e-13) and np.array_equal(d.stable, want.stable)
    assert np.allclose(d.natural_hz, want.natural_hz, rtol=1e-13)


def test_the_driver_with_a_loss_factor_and_complex_wrenches(driver):
    inputs, roots = series(1.5, 100.0, 3.0, 0.2, 1e-3, loss=0.05)
    two = {k: (np.concatenate([v, v, v]) if isinstance(v, np.ndarray) else v) for k, v in inputs.items()}
    two["K_loss"] = two["K_loss"] * np.array([1.0, 2.0, 1.0])[:, None, None]
    d = damped_modes(**two, solver="c", threads=2)
    (call,) = driver.calls
    assert call["entry"] == "complex" and call["threads"] == 2
    assert len(call["K"]) == 2 and np.array_equal(call["K_loss"][:, 0, 0], two["K_loss"][:2, 0, 0])
    assert np.iscomplexobj(call["W"]) and np.iscomplexobj(call["h"])
    want = damped_modes(**two)
    assert np.allclose(d.poles, want.poles, rtol=1e-13) and d.poles[0, 0] == d.poles[2, 0]
    # complex wrenches without K_loss: the complex route too
    driver.calls.clear()
    d = damped_modes(**{**two, "K_loss": None}, solver="c")
    assert driver.calls[0]["K_loss"] is None and np.iscomplexobj(driver.calls[0]["W"])
    assert driver.calls[0]["entry"] == "complex"
    assert np.allclose(d.poles, damped_modes(**{**two, "K_loss": None}).poles, rtol=1e-13)


@pytest.mark.parametrize("complex_part", ["W", "h", "K_loss"])
def test_the_driver_with_one_complex_input_alone(driver, complex_part):
    inputs, _ = series(1.5, 100.0, 3.0, 0.2, 1e-3)
    if complex_part == "K_loss":
        inputs["K_loss"] = 0.01 * inputs["K"]
    else:
        inputs[complex_part] = inputs[complex_part].astype(complex)
    damped_modes(**inputs, solver="c")
    assert driver.calls[0]["entry"] == "complex"


@pytest.mark.parametrize(
    "change, takes",
    [
        ({}, True),
        ({"shapes": True}, False),
        ({"G": np.zeros((1, 1, 1))}, False),
        ({"c_d": 0.2 + 0j}, False),
        ({"k_d": 3.0 + 0j}, False),
        ({"t_d": 1e-3 + 0j}, False),
    ],
)
def test_what_the_driver_takes(driver, change, takes):
    inputs, _ = series(1.5, 100.0, 3.0, 0.2, 1e-3)
    inputs = {**inputs, "t_d": 1e-3, **change}
    try:
        damped_modes(**inputs, solver="c")
    except Exception:
        assert not takes
    assert bool(driver.calls) is takes
    assert all(call["entry"] == "solve" for call in driver.calls)  # real: the real entry


def test_the_drivers_sizes(monkeypatch):
    built = []
    monkeypatch.setattr(c_damped, "driver", lambda: built.append(1) or object())
    args = [np.ones((1, 2))] * 4
    assert damped._compiled(c_damped.MAX_MODES, c_damped.MAX_LEGS, args, False, None)
    assert not damped._compiled(c_damped.MAX_MODES + 1, 1, args, False, None)
    assert not damped._compiled(1, c_damped.MAX_LEGS + 1, args, False, None)
    assert len(built) == 1  # asked only where the sizes fit
    complex_h = [np.ones((1, 2), dtype=complex)] + args[1:]
    assert damped._compiled(1, 1, complex_h, False, None)  # a complex h: the complex driver
    monkeypatch.setattr(c_damped, "driver", lambda: None)
    assert not damped._compiled(1, 1, args, False, None)


def test_a_growing_internal_pole_is_unstable():
    """h > k_d (beta < 0): the actuator's internal coordinate grows, a real pole of the cubic
    (s^2 + 4)(alpha + beta s) - D s = 0 in the right half-plane: unstable, the mode itself not."""
    inputs = one_mode(-0.1, c_d=0.1)
    roots = np.roots([-0.1, 1.0, -0.4 + 0.1, 4.0])  # beta s^3 + alpha s^2 + (4 beta - D) s + 4 alpha
    assert np.any((roots.real > 0) & (np.abs(roots.imag) < 1e-12))
    d = damped_modes(**inputs)
    assert d.stable.tolist() == [False] and d.damping_ratio[0, 0] > 0
    assert d.poles[0, 0] == pytest.approx(upper(roots)[0], rel=1e-12)


def test_a_zero_undamped_frequency_is_no_stable_model():
    """lam = 0 (a mechanism, K singular): NaN and unstable, as a negative one."""
    inputs = one_mode(1.0, c_d=0.1)
    inputs["K"] = np.zeros((1, 1, 1))
    d = damped_modes(**inputs)
    assert d.stable.tolist() == [False] and np.isnan(d.natural_hz[0, 0])


def test_an_asymmetric_stiffness_is_read_as_its_symmetric_part():
    inputs, dynamic = two_masses()
    K = np.array(inputs["K"])
    K[0, 0, 1] += 1e-3
    K[0, 1, 0] -= 1e-3
    d = damped_modes(**{**inputs, "K": K})
    assert np.allclose(d.poles, damped_modes(**inputs).poles, rtol=1e-14)


def test_one_leg_eliminated_and_one_live():
    """Leg 0 rigid along its actuator (beta = 0: eliminated), leg 1 live: the eliminated leg's
    internal coordinate decoupled (no pole of it, nothing growing), the poles those of the
    dynamic stiffness."""
    m, k_d, c_d = np.array([1.0, 2.0]), np.array([5.0, 8.0]), np.array([0.3, 0.1])
    k_s1 = 150.0
    k1 = k_s1 * k_d[1] / (k_s1 + k_d[1])
    K = np.diag([k_d[0], k1]) + 3.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    W = np.diag([k_d[0], k1])
    inputs = dict(M=np.diag(m)[None], K=K[None], W=W[None], h=np.array([[k_d[0], k1]]), k_d=k_d, c_d=c_d, t_d=0.0)

    def dynamic(s):  # leg 0: the actuator alone (Z); leg 1: k_s in series with Z
        Z = k_d + c_d * s
        legs = np.array([Z[0], 1 / (1 / k_s1 + 1 / Z[1])])
        return s * s * np.diag(m) + np.diag(legs) + 3.0 * np.array([[1.0, -1.0], [-1.0, 1.0]])

    for shapes in (False, True):
        d = damped_modes(**inputs, shapes=shapes)
        assert d.stable.tolist() == [True]
        for j in range(2):
            assert singular(dynamic(d.poles[0, j])) < 1e-10


@pytest.mark.parametrize("complex_part", ["W", "h", "K_loss"])
def test_any_complex_input_makes_the_state_matrix_complex(complex_part):
    """A loss factor reaches the solver as K_loss, complex wrenches or a complex h: each alone
    is kept (the result differs from the real problem's as the cubic says)."""
    inputs, dynamic = two_masses()
    inputs = {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in inputs.items()}
    real = damped_modes(**inputs)
    if complex_part == "K_loss":
        inputs["K_loss"] = 0.05 * inputs["K"]
    else:
        inputs[complex_part] = inputs[complex_part] * (1 + 0.05j)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = damped_modes(**inputs)
    assert not np.allclose(d.poles, real.poles, rtol=1e-6)
    assert np.all(d.poles.imag > 0) and np.all(np.isfinite(d.poles))


def coupled(D0=True):
    """Two legs on coupled bodies (G given), leg 1 undamped (c_d = t_d = 0: D = 0, y = 0): the
    same poles as leg 0 alone with G's first entry."""
    inputs, _ = two_masses(c_d=(0.3, 0.0), t_d=(0.0, 0.0))
    inputs["G"] = np.array([[[0.2, 0.05], [0.05, 0.1]]])
    return inputs


def test_an_undamped_leg_on_coupled_bodies_drops_out():
    inputs = coupled()
    d = damped_modes(**inputs)
    alone = {k: inputs[k] for k in ("M", "K")}
    alone.update(W=inputs["W"][:, :1], h=inputs["h"][:, :1], k_d=inputs["k_d"][:1], c_d=0.3, t_d=0.0)
    one = damped_modes(**alone, G=inputs["G"][:, :1, :1])
    assert np.allclose(d.poles, one.poles, rtol=1e-12) and d.stable.tolist() == [True]
    assert not np.allclose(one.poles, damped_modes(**alone).poles, rtol=1e-6)  # G counts


def test_repeated_rows_with_couplings():
    """Rows of one condition with G solved once: each as alone; rows that differ only in G are
    not one condition."""
    inputs = coupled()
    two = {k: (np.concatenate([v, v]) if isinstance(v, np.ndarray) and v.ndim == 3 else v) for k, v in inputs.items()}
    two["h"] = np.concatenate([inputs["h"], inputs["h"]])
    d = damped_modes(**two)
    one = damped_modes(**inputs)
    assert np.allclose(d.poles, np.concatenate([one.poles, one.poles]), rtol=1e-13)
    two["G"] = two["G"] * np.array([1.0, 3.0])[:, None, None]
    d = damped_modes(**two)
    assert np.allclose(d.poles[0], one.poles[0], rtol=1e-13) and not np.allclose(d.poles[1], one.poles[0], rtol=1e-6)


def test_the_driver_runs_on_one_thread_by_default(driver):
    inputs, _ = two_masses()
    damped_modes(**inputs, solver="c")
    assert driver.calls[0]["threads"] == 1


def test_a_slow_growing_mode_with_a_loss_factor_is_unstable():
    """A complex problem (a loss factor) whose mode of 0.5 rad/s grows (an eliminated leg of
    negative damping): its pole of positive frequency counts, however slow."""
    inputs = one_mode(0.0, c_d=-0.05)
    inputs.update(K=np.full((1, 1, 1), 0.25), h=np.array([[1.0]]), K_loss=np.full((1, 1, 1), 1e-4))
    d = damped_modes(**inputs)
    assert 0 < d.poles[0, 0].imag < 1 and d.poles[0, 0].real > 0 and d.stable.tolist() == [False]


def test_zero_couplings_are_no_couplings():
    """G = 0: E = diag(beta), the legs' own internal equations: the poles of the uncoupled problem
    (leg 1 with D = k_d t_d - c_d = 1 exactly)."""
    inputs, dynamic = two_masses(c_d=(0.3, 1.0), t_d=(0.0, 0.25))
    d = damped_modes(**inputs, G=np.zeros((1, 2, 2)))
    want = damped_modes(**inputs)
    assert np.allclose(d.poles, want.poles, rtol=1e-12)
    for j in range(2):
        assert singular(dynamic(d.poles[0, j])) < 1e-10


def test_three_masses_shapes_are_the_null_vectors():
    """A chain of three masses, a leg on each: every shape the null vector of the dynamic
    stiffness at its pole, its entry of largest magnitude 1."""
    m = np.array([1.0, 0.3, 2.0])
    k_s, k_d, c_d = np.array([200.0, 150.0, 90.0]), np.array([5.0, 8.0, 4.0]), np.array([0.3, 0.1, 0.2])
    k0 = k_s * k_d / (k_s + k_d)
    chain = np.array([[4.0, -4.0, 0.0], [-4.0, 10.0, -6.0], [0.0, -6.0, 6.0]])
    inputs = dict(M=np.diag(m)[None], K=(np.diag(k0) + chain)[None], W=np.diag(k0)[None], h=k0[None])
    d = damped_modes(**inputs, k_d=k_d, c_d=c_d, t_d=0.0, shapes=True)

    def dynamic(s):
        return s * s * np.diag(m) + np.diag(1 / (1 / k_s + 1 / (k_d + c_d * s))) + chain

    for j in range(3):
        x = d.shapes[0, :, j]
        assert x[np.argmax(np.abs(x))] == pytest.approx(1.0, abs=1e-15)
        assert np.linalg.norm(dynamic(d.poles[0, j]) @ x) < 1e-9 * np.linalg.norm(dynamic(d.poles[0, j]))


@pytest.mark.parametrize("order", [(0, 1, 2, 3), (3, 2, 1, 0), (1, 3, 0, 2)])
def test_real_poles_of_equal_share_give_the_slower_whatever_their_order(order):
    """A decoupled subsystem's real poles share a mode equally (1 each, to round-off): the
    overdamped mode takes the slowest and pairs it with the next slowest, in whatever order
    the eigenvalue solver returns them; a share larger by more than SHARE_TIE wins over a
    slower pole."""
    s0 = np.array([-20.0 + 0j, -70.0 + 0j, -800.0 + 0j, -5.0 + 0j])
    share0 = np.array([[1.0, 1.0 - 1e-15, 1.0, damped.SHARE_TIE / 2]])  # the fourth pole: outside the tie
    share0[0, 3] = 1.0 - 2 * damped.SHARE_TIE
    idx = np.array(order)
    s, share = s0[idx], share0[:, idx]
    wn, zeta, wd, poles, _ = damped._assign(s[None], share[None], 1)
    assert poles[0, 0] == -20.0 and wn[0, 0] == pytest.approx(np.sqrt(20.0 * 70.0), rel=1e-15) and wd[0, 0] == 0.0
    # within the tie, the slower pole wins
    share1 = share0.copy()
    share1[0, 3] = 1.0 - damped.SHARE_TIE / 2
    wn, _, _, poles, _ = damped._assign(s[None], share1[:, idx][None], 1)
    assert poles[0, 0] == -5.0 and wn[0, 0] == pytest.approx(np.sqrt(5.0 * 20.0), rel=1e-15)
