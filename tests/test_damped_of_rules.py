"""The damped modes of an evaluator's model (:func:`eigentwist.runtime.damped_modes.damped_of`) on a
stand-in evaluator: three legs of two elastic joints each (the actuated joint first) on a six-twist
platform, written here. Each pole is checked against the dynamic stiffness written from the joint
compliances (Eqs. 41-43): ``D(s) = B^T (s^2 M + K(s)) B`` with each leg's
``J_e^T C_q(s)^+ J_e``, ``C_q(s) = C_s + e_0 e_0^T / Z(s)``, ``Z(s) = (k_d + c_d s) / (1 + t_d s)``
and ``C_s = C_q(0) - e_0 e_0^T / k_d`` the passive structure: a pole makes ``D(s)`` singular, its
shape is ``D(s)``'s null vector. No kernel, no compile.
"""

from __future__ import annotations

from types import SimpleNamespace as NS

import numpy as np
import pytest
import scipy.linalg

from eigentwist.runtime import condense
from eigentwist.runtime import damped_modes as dm
from eigentwist.runtime import gravity

LEGS, JOINTS = 3, 2
K_A, C_A, T_D = 2000.0, 4.0, 1e-3
#: the poles come from an eigenvalue problem of condition ~1e3 here (round-off 1e-16): a pole's
#: dynamic stiffness is singular to ~1e-12 of its norm; a wrong matrix anywhere leaves >= 1e-4
SINGULAR = 1e-8


class StandIn:
    """The evaluator's side :func:`damped_of` reads: legs, couplings, the stiffness model, the
    backend, the allowed twists of the rigid model."""

    def __init__(self, rigid=False, couplings=(), bodies=None, basis=None, effects=()):
        self.n_legs = LEGS
        self.effects = effects
        self.backend = "numpy"
        self.threads = 1
        self.robot = NS(couplings=list(couplings), legs=[NS(platform_body=b) for b in (bodies or ["platform"] * LEGS)])
        self.rigid = rigid
        self.basis = basis
        self.asked = []
        self.models = []

    def stiffness_model(self, effects):
        self.models.append(tuple(effects))  # the effects' model, asked with the effects
        return "rigid" if self.rigid else "flexible"

    def allowed_twists(self, poses, **params):
        self.asked.append((np.array(poses), params))
        return np.broadcast_to(self.basis, (len(poses), 6, self.basis.shape[-1]))


def structure(n=2, rigid_joint=False, seed=3):
    """Je (n, legs, 2, 6), Cq (n, legs, 2, 2) with the actuator's 1/k_d in Cq[0, 0], M, K_ground:
    each pose's rows scaled differently (the poses are not one row broadcast)."""
    rng = np.random.default_rng(seed)
    Je0 = rng.normal(size=(LEGS, JOINTS, 6))
    Je = np.stack([Je0 * (1.0 + 0.1 * k) for k in range(n)])
    Cs = np.array([[[4e-4, 1e-4], [1e-4, 3e-4]], [[5e-4, -5e-5], [-5e-5, 2e-4]], [[3e-4, 0.0], [0.0, 6e-4]]])
    if rigid_joint:  # the last leg's passive joint rigid
        Cs[2] = np.diag([3e-4, 0.0])
    Cq = np.broadcast_to(Cs, (n, LEGS, JOINTS, JOINTS)).copy()
    Cq[:, :, 0, 0] += 1.0 / K_A
    M = np.diag([3.0, 3.5, 4.0, 0.05, 0.06, 0.08])
    M[0, 4] = M[4, 0] = 0.02
    K_ground = np.diag([100.0, 200.0, 300.0, 10.0, 20.0, 30.0])
    return Je, Cq, M, K_ground


def leg_stiffness(Je, Cq, s, c_d=0.0, t_d=0.0, loss=0.0, k_d=K_A):
    """J_e^T C_q(s)^+ J_e of one leg (a rigid joint combination stays rigid: the pseudo-inverse)."""
    C = np.array(Cq, dtype=complex)
    C[0, 0] -= 1.0 / k_d
    C = C / (1 + 1j * loss)
    C[0, 0] += (1 + t_d * s) / (k_d + c_d * s)
    return Je.T @ np.linalg.pinv(C, rcond=1e-10) @ Je


def dynamic(s, pose, Je, Cq, M, K_model, B, loss=0.0, c_d=C_A, t_d=T_D, k_d=K_A):
    """B^T (s^2 M + K_model + sum_i (K_i(s) - K_i(0))) B."""
    K = np.array(K_model, dtype=complex)
    for i in range(LEGS):
        K += leg_stiffness(Je[pose, i], Cq[pose, i], s, c_d, t_d, loss, k_d)
        K -= leg_stiffness(Je[pose, i], Cq[pose, i], 0.0, k_d=k_d).real
    return B.T @ (s * s * M + K) @ B


def relative_singularity(D):
    sv = np.linalg.svd(D, compute_uv=False)
    return sv[-1] / sv[0]


def undamped_hz(K, M):
    return np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)) / (2 * np.pi)


def modes_of(freq, stable=None, eigentwists=None):
    return NS(
        freq_hz=freq, stable=np.ones(len(freq), dtype=bool) if stable is None else stable, eigentwists=eigentwists
    )


def params(c_a=C_A, t_d=T_D, eta_s=0.0):
    return {"k_a": K_A, "c_a": c_a, "t_d": t_d, "eta_s": eta_s}


def inputs_of(rows, Je, Cq, M, K_ground, mats, B=None, exact=True, preloaded=False, p=None):
    n = int(np.sum(rows))
    return {
        "rows": rows,
        "poses": np.tile([0.01, -0.02, -0.6], (n, 1)) + 0.01 * np.arange(n)[:, None],
        "params": {"k_a": K_A},
        "p": params() if p is None else p,
        "legs": {"Je": Je, "Cq": Cq, "K_ground": K_ground},
        "mats": mats,
        "B": B,
        "exact": exact,
        "preloaded": preloaded,
    }


def flexible_case(rigid_joint=False, n_rows=3, invalid=1, K_F=None):
    """Rows of which ``invalid`` is not valid; the flexible model's K_F = the legs' springs + K_ground."""
    Je, Cq, M, K_ground = structure(n_rows - (invalid is not None), rigid_joint)
    n = len(Je)
    K_legs = [sum(leg_stiffness(Je[k, i], Cq[k, i], 0.0).real for i in range(LEGS)) for k in range(n)]
    K_F = np.array([K + K_ground for K in K_legs]) if K_F is None else K_F
    rows = np.ones(n_rows, dtype=bool)
    if invalid is not None:
        rows[invalid] = False
    freq = np.full((n_rows, 6), np.nan)
    freq[rows] = [undamped_hz(K, M) for K in K_F]
    return Je, Cq, M, K_ground, K_F, rows, freq


def check_poles(d, rows, case_of_pose, tol=SINGULAR, m=None):
    """Every pole of a valid row makes its dynamic stiffness singular; one pole a mode."""
    for k, row in enumerate(np.flatnonzero(rows)):
        D_of = case_of_pose(k)
        m = m or D_of(0.0).shape[0]
        poles = d.poles[row, :m]
        assert np.all(poles.imag > 0) and len(np.unique(np.round(poles, 6))) == m
        for s in poles:
            assert relative_singularity(D_of(s)) < tol, (row, s)


def test_flexible_model_poles_are_the_dynamic_stiffness_roots():
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case()
    ev = StandIn()
    modes = modes_of(freq.copy(), stable=np.array([True, False, True]))
    d = dm.damped_of(
        ev, ("servo_damping", "servo_delay"), inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}), modes, False
    )
    B = np.eye(6)
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], B))
    # each mode stays near the undamped one it grows from, damped (a stable servo)
    assert np.all(d.damping_ratio[rows] > 0) and np.allclose(d.damped_hz[rows], d.poles[rows].imag / (2 * np.pi))
    assert np.allclose(d.natural_hz[rows], freq[rows], rtol=0.3)
    assert np.allclose(d.natural_hz[rows], np.abs(d.poles[rows]) / (2 * np.pi), rtol=1e-12)
    # the invalid row keeps the undamped frequencies (NaN) and NaN damping; its stability as given
    assert np.all(np.isnan(d.natural_hz[1])) and np.all(np.isnan(d.damping_ratio[1])) and np.all(np.isnan(d.poles[1]))
    assert d.stable.tolist() == [True, False, True] and d.shapes is None
    # an undamped model unstable at a valid pose stays unstable, however the damped poles lie
    modes.stable = np.array([False, True, True])
    d = dm.damped_of(
        ev, ("servo_damping", "servo_delay"), inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}), modes, False
    )
    assert d.stable.tolist() == [False, True, True]
    assert np.array_equal(modes.freq_hz, freq, equal_nan=True)  # the undamped modes are not written


def test_undamped_limit_is_the_models_frequencies():
    """c_a = t_d = 0: every pole is i 2 pi f of the model's undamped frequencies, column by column."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=2)
    d = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}, p=params(0.0, 0.0)),
        modes_of(freq),
        False,
    )
    assert np.allclose(d.poles.imag / (2 * np.pi), freq, rtol=1e-10)
    assert np.allclose(d.natural_hz, freq, rtol=1e-10) and np.allclose(d.damped_hz, freq, rtol=1e-10)
    assert np.allclose(d.damping_ratio, 0.0, atol=1e-10) and d.stable.all()


@pytest.mark.parametrize(
    "effects, c_d, t_d", [((), 0.0, 0.0), (("servo_damping",), C_A, 0.0), (("servo_delay",), 0.0, T_D)]
)
def test_only_the_damping_effects_that_are_on(effects, c_d, t_d):
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    d = dm.damped_of(
        StandIn(), effects, inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}), modes_of(freq), False
    )
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6), c_d=c_d, t_d=t_d))


def test_no_valid_row_leaves_the_undamped_modes():
    freq = np.array([[1.0, 2.0, 3.0], [np.nan] * 3])
    modes = modes_of(freq, stable=np.array([True, False]))
    d = dm.damped_of(StandIn(), ("servo_damping",), None, modes, True)
    assert np.array_equal(d.natural_hz, freq, equal_nan=True) and np.array_equal(d.damped_hz, freq, equal_nan=True)
    assert d.natural_hz is not modes.freq_hz and d.damped_hz is not d.natural_hz
    assert np.all(np.isnan(d.damping_ratio)) and np.all(np.isnan(d.poles)) and np.iscomplexobj(d.poles)
    assert d.shapes.shape == (2, 3, 3) and np.all(np.isnan(d.shapes)) and np.iscomplexobj(d.shapes)
    assert d.stable.tolist() == [True, False] and d.stable is not modes.stable
    assert dm.damped_of(StandIn(), (), None, modes, False).shapes is None


def test_shapes_are_the_null_vectors_with_largest_entry_one():
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case()
    d = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}),
        modes_of(freq),
        True,
    )
    assert np.all(np.isnan(d.shapes[1]))
    for k, row in enumerate(np.flatnonzero(rows)):
        X = d.shapes[row]
        assert np.allclose(np.max(np.abs(X), axis=0), 1.0, rtol=1e-12)
        assert np.allclose(X[np.argmax(np.abs(X), axis=0), np.arange(6)], 1.0, rtol=1e-12)
        for j in range(6):
            D = dynamic(d.poles[row, j], k, Je, Cq, M, K_F[k], np.eye(6))
            assert np.linalg.norm(D @ X[:, j]) < SINGULAR * np.linalg.norm(D)


def test_rigid_directions_restrict_the_twists_where_the_route_is_exact():
    """A leg whose passive joint is rigid: the exact route keeps the five twists it allows, with the
    legs' finite springs (K_F's penalty along the rigid row left out); columns beyond them keep
    the undamped mode, damping 0, and the model's eigentwist."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(rigid_joint=True, invalid=None, n_rows=2)
    rigid_row = Je[:, 2, 1, :]  # (n, 6)
    K_pen = K_F + 1e9 * rigid_row[:, :, None] * rigid_row[:, None, :]  # a penalty model's K_F
    eig = np.broadcast_to(np.arange(36.0).reshape(6, 6), (2, 6, 6))
    modes = modes_of(freq, eigentwists=eig)
    d = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_pen}),
        modes,
        True,
    )
    Bs = [scipy.linalg.null_space(rigid_row[k][None, :]) for k in range(2)]
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], Bs[k]))
    assert np.array_equal(d.damping_ratio[:, 5], [0.0, 0.0]) and np.all(np.isnan(d.poles[:, 5]))
    assert np.array_equal(d.natural_hz[:, 5], freq[:, 5]) and np.array_equal(d.damped_hz[:, 5], freq[:, 5])
    assert np.array_equal(d.shapes[:, :, 5], eig[:, :, 5])
    for k in range(2):  # the shapes are twists: in the allowed ones, of largest entry 1
        X = d.shapes[k, :, :5]
        assert np.allclose(rigid_row[k] @ X, 0.0, atol=1e-9)
        assert np.allclose(np.max(np.abs(X), axis=0), 1.0)
    # the evaluator's own basis where its condensation found one (here: the same twists)
    given = np.stack(Bs)
    d2 = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M}, B=given, exact=False),
        modes,
        False,
    )
    assert np.allclose(d2.poles[:, :5], d.poles[:, :5], rtol=1e-10)
    # a route that does not condense (a penalty model): the six twists and K_F as it is
    d3 = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_pen}, exact=False),
        modes_of(freq),
        False,
    )
    check_poles(d3, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_pen[k], np.eye(6)), tol=1e-6)


def test_six_given_twists_without_K_F_use_the_legs_springs():
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    B = np.eye(6)[None]
    d = dm.damped_of(
        StandIn(), ("servo_damping",), inputs_of(rows, Je, Cq, M, K_ground, {"M": M}, B=B), modes_of(freq), False
    )
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6), t_d=0.0))


def test_structural_loss_makes_the_passive_compliance_hysteretic():
    """eta_s: C_s / (1 + i eta_s) (the actuator's own 1/k_d not), with the model's K_F on six twists."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=2)
    p = params(eta_s=0.05)
    d = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay", "structural_loss"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}, p=p),
        modes_of(freq),
        False,
    )

    def D(k):
        return lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6), loss=0.05)

    check_poles(d, rows, D)
    plain = dm.damped_of(
        StandIn(),
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}, p=p),
        modes_of(freq),
        False,
    )
    assert np.all(d.damping_ratio > plain.damping_ratio)  # the loss adds damping to every mode


def test_rigid_model_on_its_allowed_twists():
    """The rigid model: K_R on the allowed twists, each leg's actuated joint alone in series with
    its actuator (the passive joints left out)."""
    Je, Cq, M, K_ground = structure(2)
    basis = np.eye(6)[:, 3:]  # translations
    a = Je[:, :, 0, :]  # actuated rows
    c0 = Cq[:, :, 0, 0]
    K_R = np.einsum("nl,nli,nlj->nij", 1.0 / c0, a, a)
    K_R = K_R + 1e3 * np.eye(6)  # the model's stiffness: not the legs' alone
    rows = np.array([True, True, False])
    freq = np.full((3, 3), np.nan)
    freq[:2] = [undamped_hz(basis.T @ K @ basis, basis.T @ M @ basis) for K in K_R]
    # a coupling of platform bodies that is on: the rigid model's bodies are rigid (no couplings read)
    ev = StandIn(rigid=True, basis=basis, couplings=[NS(body="arm", effect="arm_coupling")], bodies=["arm"] * LEGS)
    inp = inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_R": K_R})
    d = dm.damped_of(ev, ("servo_damping", "servo_delay", "arm_coupling"), inp, modes_of(freq), True)
    assert len(ev.asked) == 1 and np.array_equal(ev.asked[0][0], inp["poses"]) and ev.asked[0][1] == {"k_a": K_A}

    def D(k):
        def f(s):
            K = K_R[k] + sum(
                (1.0 / (c0[k, i] - 1 / K_A + (1 + T_D * s) / (K_A + C_A * s)) - 1.0 / c0[k, i])
                * np.outer(a[k, i], a[k, i])
                for i in range(LEGS)
            )
            return basis.T @ (s * s * M + K) @ basis

        return f

    check_poles(d, rows, D)
    assert d.shapes.shape == (3, 3, 3) and np.all(np.isnan(d.shapes[2]))
    for k in range(2):
        for j in range(3):
            Dk = D(k)(d.poles[k, j])
            assert np.linalg.norm(Dk @ d.shapes[k, :, j]) < SINGULAR * np.linalg.norm(Dk)


def test_gravity_preload_in_parallel(monkeypatch):
    """The preload's stiffness (:func:`.gravity.gravity_stiffness`, a stand-in here) adds to the
    model's: the flexible model's on the twists B, the rigid model's as given (on its allowed twists)."""
    K_G6 = np.diag([-20.0, -30.0, 5.0, -1.0, 2.0, -3.0])
    K_G6[1, 3] = K_G6[3, 1] = 1.5
    seen = []

    def stand_in(ev, poses, effects, params, mats, rigid, basis=None):
        assert isinstance(ev, StandIn) and effects == ("servo_damping",) and params == {"k_a": K_A}
        assert np.array_equal(mats["M"], np.broadcast_to(M, (2, 6, 6))) and np.array_equal(mats["K_F"], K_F)
        assert np.array_equal(poses, inputs_of(rows, Je, Cq, M, K_ground, {})["poses"])
        seen.append((rigid, basis is None, sorted(mats), mats["M"].shape))
        return np.broadcast_to(K_G6[3:, 3:] if rigid else K_G6, (len(poses),) + ((3, 3) if rigid else (6, 6)))

    monkeypatch.setattr(gravity, "gravity_stiffness", stand_in)
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=2)
    mats = {"M": M, "K_R": K_F, "K_F": K_F}
    d = dm.damped_of(
        StandIn(), ("servo_damping",), inputs_of(rows, Je, Cq, M, K_ground, mats, preloaded=True), modes_of(freq), False
    )
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k] + K_G6, np.eye(6), t_d=0.0))
    assert seen == [(False, True, ["K_F", "K_R", "M"], (2, 6, 6))]
    # the rigid model: K_G on its allowed twists, added as it is
    basis = np.eye(6)[:, 3:]
    a, c0 = Je[:, :, 0, :], Cq[:, :, 0, 0]
    K_R = np.einsum("nl,nli,nlj->nij", 1.0 / c0, a, a) + 1e3 * np.eye(6)
    freq3 = np.array([undamped_hz(basis.T @ K @ basis + K_G6[3:, 3:], basis.T @ M @ basis) for K in K_R])
    mats = {"M": M, "K_R": K_R, "K_F": K_F}
    d = dm.damped_of(
        StandIn(rigid=True, basis=basis),
        ("servo_damping",),
        inputs_of(rows, Je, Cq, M, K_ground, mats, preloaded=True),
        modes_of(freq3),
        False,
    )
    assert seen[-1] == (True, False, ["K_F", "K_R", "M"], (2, 6, 6))

    def D(k):
        def f(s):
            K = K_R[k] + sum(
                (1.0 / (c0[k, i] - 1 / K_A + 1.0 / (K_A + C_A * s)) - 1.0 / c0[k, i]) * np.outer(a[k, i], a[k, i])
                for i in range(LEGS)
            )
            return basis.T @ (s * s * M + K) @ basis + K_G6[3:, 3:]

        return f

    check_poles(d, rows, D)


def test_legs_on_a_coupled_body():
    """The second leg on a body joined to the platform by a compliant coupling of one coordinate
    theta (its twist t - g theta): D(s) on x = [t; theta] with no inertia on theta is singular
    at each pole (its Schur complement on t is the condensed dynamic stiffness)."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=2)
    g = np.array([0.1, 0.0, -0.2, 1.0, 0.3, 0.0])
    k_c = 5e3
    ev = StandIn(couplings=[NS(body="arm", effect="arm_coupling")], bodies=["platform", "arm", "platform"])
    legs_extra = {"G_c": g[None, :, None], "K_c": np.array([[k_c]])}
    T = [np.eye(6, 7), np.hstack([np.eye(6), -g[:, None]]), np.eye(6, 7)]

    def D(k):
        def f(s):
            Dx = np.zeros((7, 7), dtype=complex)
            Dx[:6, :6] = s * s * M + K_ground
            Dx[6, 6] = k_c
            for i in range(LEGS):
                Dx += T[i].T @ leg_stiffness(Je[k, i], Cq[k, i], s, C_A, T_D) @ T[i]
            return Dx

        return f

    freq_c = np.array([np.sort(np.abs(np.linalg.eigvals(np.eye(6)))) for _ in range(2)])  # not read here
    inp = inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F})
    inp["legs"].update(legs_extra)
    d = dm.damped_of(ev, ("servo_damping", "servo_delay", "arm_coupling"), inp, modes_of(freq_c), True)
    check_poles(d, rows, D, m=6)
    for k in range(2):  # the shape: the platform's twist part of D(s)'s null vector
        for j in range(6):
            _, _, Vh = np.linalg.svd(D(k)(d.poles[k, j]))
            t = Vh[-1].conj()[:6]
            t = t / t[np.argmax(np.abs(t))]
            assert np.allclose(d.shapes[k, :, j], t, atol=1e-7)
    # the coupling off: the legs all on the platform
    inp["legs"] = {k: v for k, v in inp["legs"].items()}
    off = dm.damped_of(ev, ("servo_damping", "servo_delay"), inp, modes_of(freq), False)
    check_poles(off, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6)))


# -- the C route's decisions, with a stand-in driver (no compile) --------------------------------------------


class Driver:
    """A stand-in of :func:`.c_damped.solve_legs`: it records what it is given and decides the
    distinct rows it is told to (made-up poles s = -1 + i 2 pi (j + 1)), leaving the others undecided."""

    def __init__(self, decide=None):
        self.calls = []
        self.decide = decide

    def __call__(self, M, K, Kg, Je, Cq, e, B, k_d, c_d, t_d, rules, threads):
        self.calls.append(
            dict(M=M, K=K, Kg=Kg, Je=Je, Cq=Cq, e=e, B=B, k_d=k_d, c_d=c_d, t_d=t_d, rules=rules, threads=threads)
        )
        n, r = len(Je), (6 if B is None else np.shape(B)[-1])
        poles = np.broadcast_to(-1.0 + 2j * np.pi * np.arange(1.0, r + 1), (n, r)).copy()
        redo = np.zeros(n, dtype=bool) if self.decide is None else ~np.asarray(self.decide(n))
        return np.abs(poles), -poles.real / np.abs(poles), poles.imag, poles, np.ones(n, dtype=bool), redo


@pytest.fixture
def driver(monkeypatch):
    from eigentwist.runtime import c_damped

    fake = Driver()
    monkeypatch.setattr(c_damped, "driver", lambda: object())
    monkeypatch.setattr(c_damped, "solve_legs", fake)
    monkeypatch.setattr(c_damped, "wrenches", lambda *a: None)  # the batch wrenches: not built
    return fake


def made_up(r):
    s = -1.0 + 2j * np.pi * np.arange(1.0, r + 1)
    return s, np.abs(s) / (2 * np.pi), s.imag / (2 * np.pi), -s.real / np.abs(s)


def test_one_c_call_from_the_legs_where_the_driver_takes_the_problem(driver):
    from eigentwist.runtime import damped as damped_module

    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case()
    ev = StandIn()
    ev.backend = "c"
    ev.threads = 3
    d = dm.damped_of(
        ev,
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}),
        modes_of(freq),
        False,
    )
    (call,) = driver.calls
    s, natural, damped, zeta = made_up(6)
    assert (
        np.allclose(d.poles[rows], s)
        and np.allclose(d.natural_hz[rows], natural)
        and np.allclose(d.damped_hz[rows], damped)
    )
    assert np.allclose(d.damping_ratio[rows], zeta) and np.all(np.isnan(d.poles[1]))
    assert call["rules"] == (
        damped_module.RIGID,
        damped_module.ELIMINATE,
        damped_module.UNSTABLE_ZETA,
        damped_module.AMBIGUOUS,
    )
    assert call["threads"] == 3 and call["e"] == JOINTS and np.array_equal(call["K"], K_F)
    assert np.array_equal(call["Kg"], K_ground) and np.allclose(call["B"], np.eye(6))
    assert np.array_equal(call["k_d"], np.full((2, LEGS), K_A)) and np.array_equal(call["c_d"], np.full((2, LEGS), C_A))
    assert np.array_equal(call["t_d"], np.full((2, LEGS), T_D)) and np.array_equal(call["Je"], Je)
    # the rigid model: its stiffness on its allowed twists, the actuated joints alone, no ground
    basis = np.eye(6)[:, 3:]
    ev = StandIn(rigid=True, basis=basis)
    ev.backend = "c"
    rows2 = np.array([True, True])
    dm.damped_of(
        ev,
        ("servo_damping",),
        inputs_of(rows2, Je, Cq, M, K_ground, {"M": M, "K_R": K_F}),
        modes_of(np.ones((2, 3))),
        False,
    )
    call = driver.calls[-1]
    assert (
        call["Kg"] is None
        and call["e"] == 1
        and call["Je"].shape == (2, LEGS, 1, 6)
        and call["Cq"].shape == (2, LEGS, 1, 1)
    )
    assert np.array_equal(np.broadcast_to(call["B"], (2, 6, 3)), np.broadcast_to(basis, (2, 6, 3)))
    assert np.array_equal(call["K"], K_F)


@pytest.mark.parametrize("effects, shapes", [(("servo_damping", "structural_loss"), False), (("servo_damping",), True)])
def test_the_legs_driver_does_not_take_a_loss_factor_or_shapes(driver, monkeypatch, effects, shapes):
    """Neither goes to the one C call from the legs; a loss factor goes to the complex C solver
    (here a stand-in that solves in NumPy), complex shapes to NumPy."""
    from eigentwist.runtime import c_damped, damped

    complex_calls = []

    def solve_complex(M, K, K_loss, W, h, k_d, c_d, t_d, *rules, threads=1):
        complex_calls.append(K_loss is not None)
        d = damped.damped_modes(M, K, W, h, k_d, c_d, t_d, K_loss=K_loss)
        two_pi = 2 * np.pi
        return d.natural_hz * two_pi, d.damping_ratio, d.damped_hz * two_pi, d.poles, d.stable, np.zeros(len(K), bool)

    monkeypatch.setattr(c_damped, "solve_complex", solve_complex)
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    ev = StandIn()
    ev.backend = "c"
    p = params(eta_s=0.02)
    d = dm.damped_of(
        ev, effects, inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}, p=p), modes_of(freq), shapes
    )
    assert driver.calls == []
    assert complex_calls == ([True] if "structural_loss" in effects else [])
    loss = 0.02 if "structural_loss" in effects else 0.0
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6), loss=loss, t_d=0.0))


def test_without_a_driver_the_c_backend_solves_in_numpy(monkeypatch):
    from eigentwist.runtime import c_damped

    monkeypatch.setattr(c_damped, "driver", lambda: None)
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    ev = StandIn()
    ev.backend = "c"
    d = dm.damped_of(
        ev,
        ("servo_damping", "servo_delay"),
        inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}),
        modes_of(freq),
        False,
    )
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k], np.eye(6)))


def test_from_legs_solves_each_distinct_row_once_and_the_undecided_in_numpy(driver):
    """Four poses of two distinct rows (0 = 2, 1 = 3): the driver sees two; it decides the first,
    leaves the second to NumPy (the legs' springs + K_ground where no model stiffness is given)."""
    Je2, Cq2, M, K_ground, K_F, _, _ = flexible_case(invalid=None, n_rows=2)
    take = [0, 1, 0, 1]
    Je, Cq = Je2[take], Cq2[take]
    k_d, c_d, t_d = (np.full((4, LEGS), v) for v in (K_A, C_A, T_D))
    driver.decide = lambda n: np.arange(n) == 0
    d = dm._from_legs(
        np.broadcast_to(M, (4, 6, 6)), None, K_ground, Je, Cq, np.eye(6)[None].repeat(4, 0), k_d, c_d, t_d, 2
    )
    (call,) = driver.calls
    assert len(call["Je"]) == 2 and np.array_equal(call["Je"], Je2) and call["threads"] == 2
    assert call["M"].shape == (2, 6, 6) and call["K"] is None and np.array_equal(call["Kg"], K_ground)
    s, natural, damped, zeta = made_up(6)
    for k in (0, 2):
        assert (
            np.allclose(d.poles[k], s)
            and np.allclose(d.natural_hz[k], natural)
            and np.allclose(d.damping_ratio[k], zeta)
        )
        assert np.allclose(d.damped_hz[k], damped)
    assert np.array_equal(d.poles[1], d.poles[3]) and d.shapes is None and d.stable.all()
    check_poles(d, np.array([False, True]), lambda k: lambda s: dynamic(s, 1, Je2, Cq2, M, K_F[1], np.eye(6)))
    # a model stiffness given: it, not the legs' springs
    driver.decide = lambda n: np.zeros(n, dtype=bool)
    K_model = K_F + np.diag([50.0, 0, 0, 0, 0, 5.0])
    d = dm._from_legs(M[None], K_model[[1]], None, Je2[[1]], Cq2[[1]], np.eye(6)[None], k_d[:1], c_d[:1], t_d[:1], 1)
    check_poles(d, np.array([True]), lambda k: lambda s: dynamic(s, 0, Je2[[1]], Cq2[[1]], M, K_model[1], np.eye(6)))


def test_from_legs_within_the_drivers_sizes(driver):
    from eigentwist.runtime import c_damped

    M = np.broadcast_to(np.eye(6), (1, 6, 6))
    for L, e, r, takes in [
        (c_damped.MAX_LEGS, 1, 6, True),
        (c_damped.MAX_LEGS + 1, 1, 6, False),
        (1, c_damped.MAX_MODES, 6, True),
        (1, c_damped.MAX_MODES + 1, 6, False),
        (1, 1, 7, False),
    ]:
        Je = np.zeros((1, L, e, 6))
        Je[..., 0, :] = 1.0
        Cq = np.broadcast_to(np.eye(e), (1, L, e, e))
        k = np.ones((1, L))
        d = dm._from_legs(M, np.eye(6)[None], None, Je, Cq, np.zeros((1, 6, r)), k, k, k, 1)
        assert (d is not None) is takes, (L, e, r)


def test_shared_rows():
    one = np.broadcast_to(np.arange(4.0).reshape(2, 2), (5, 2, 2))
    assert dm._shared(one, 5).shape == (2, 2)  # a broadcast row: once
    assert dm._shared(np.ones((1, 2, 2)), 1).shape == (2, 2)
    assert dm._shared(np.ones((1, 2, 2)), 0).shape == (1, 2, 2)
    own = np.arange(20.0).reshape(5, 2, 2)
    assert dm._shared(own, 5) is not None and np.array_equal(dm._shared(own, 5), own)
    assert dm._shared(np.ones((2, 2)), 5).shape == (2, 2) and dm._shared(np.ones((3, 2, 2)), 3).shape == (3, 2, 2)


def kernels_with(L=3, e=2, c=6, fused=True):
    k = NS(OUTPUTS={"legs": {"Je": (L, e, c), "Cq": (L, e, e)}})
    if fused:
        k.fused_arguments = lambda *a, **kw: None
    return k


@pytest.mark.parametrize(
    "kernels, effects, driver_built, takes",
    [
        (kernels_with(), ("servo_damping",), True, True),
        (kernels_with(), ("servo_damping",), False, False),
        (kernels_with(), ("servo_damping", "structural_loss"), True, False),
        (kernels_with(), ("servo_damping", "arm_coupling"), True, False),
        (kernels_with(fused=False), (), True, False),
        (NS(OUTPUTS={"legs": {"Je": (3, 2, 6)}}, fused_arguments=None), (), True, False),
        (NS(OUTPUTS={"legs": {"Cq": (3, 2, 2)}}, fused_arguments=None), (), True, False),
        (NS(fused_arguments=None), (), True, False),
        (kernels_with(L=16), (), True, True),
        (kernels_with(L=17), (), True, False),
        (kernels_with(e=12), (), True, True),
        (kernels_with(e=13), (), True, False),
        (kernels_with(c=5), (), True, False),
    ],
)
def test_one_pass_takes(monkeypatch, kernels, effects, driver_built, takes):
    from eigentwist.runtime import c_damped

    assert (c_damped.MAX_LEGS, c_damped.MAX_MODES) == (16, 12)
    monkeypatch.setattr(c_damped, "driver", lambda: object() if driver_built else None)
    ev = NS(kernels=kernels, robot=NS(couplings=[NS(body="arm", effect="arm_coupling")]))
    assert dm.one_pass_takes(ev, effects) is takes


def test_pass_damping_keeps_the_decided_poses_and_solves_the_undecided():
    """Three poses of the fused pass: the first decided by the driver, the second not valid, the
    third undecided: solved from the pass's kernel outputs on the six twists and the model's K_F."""
    Je2, Cq2, M, K_ground, K_F2, _, freq2 = flexible_case(invalid=None, n_rows=2)
    take = [0, 0, 1]
    Je, Cq, K_F = Je2[take], Cq2[take], K_F2[take]
    freq = freq2[take]
    freq[1] = np.nan
    s, natural, damped, zeta = made_up(6)
    poles = np.broadcast_to(s, (3, 6)).copy()
    solved = {
        "poles": (
            np.abs(poles),
            zeta * np.ones((3, 1)),
            poles.imag,
            poles.copy(),
            np.array([True, True, False]),
            np.array([False, True, True]),
        ),
        "legs": {"Je": Je, "Cq": Cq, "K_ground": K_ground},
        "stiffness": "K_F",
        "M": np.broadcast_to(M, (3, 6, 6)),
        "K": K_F,
    }
    modes = NS(freq_hz=freq, valid=np.array([True, False, True]), stable=np.array([True, True, True]), eigentwists=None)
    d = dm.pass_damping(
        StandIn(), ("servo_damping", "servo_delay"), np.zeros((3, 3)), {"k_a": np.full(3, K_A)}, params(), solved, modes
    )
    assert np.allclose(d.poles[0], s) and np.allclose(d.natural_hz[0], natural) and np.allclose(d.damped_hz[0], damped)
    assert np.allclose(d.damping_ratio[0], zeta)
    assert np.all(np.isnan(d.natural_hz[1])) and np.all(np.isnan(d.damping_ratio[1])) and np.all(np.isnan(d.poles[1]))
    check_poles(d, np.array([False, False, True]), lambda k: lambda s: dynamic(s, 1, Je2, Cq2, M, K_F2[1], np.eye(6)))
    assert d.stable.tolist() == [True, True, True] and d.shapes is None
    # a pose the driver finds unstable stays so; a not-valid one keeps the undamped model's verdict
    solved["poles"] = (
        np.abs(poles),
        zeta * np.ones((3, 1)),
        poles.imag,
        poles.copy(),
        np.array([False, False, True]),
        np.zeros(3, dtype=bool),
    )
    modes.stable = np.array([True, False, True])
    d = dm.pass_damping(StandIn(), ("servo_damping",), np.zeros((3, 3)), {}, params(), solved, modes)
    assert d.stable.tolist() == [False, False, True]
    modes.valid, modes.stable = None, np.ones(3, dtype=bool)
    solved["poles"] = (
        np.abs(poles),
        zeta * np.ones((3, 1)),
        poles.imag,
        poles.copy(),
        np.ones(3, dtype=bool),
        np.zeros(3, dtype=bool),
    )
    d = dm.pass_damping(StandIn(), ("servo_damping",), np.zeros((3, 3)), {}, params(), solved, modes)
    assert np.allclose(d.poles, poles) and d.stable.all()


class Kernels:
    """The C kernels' side :func:`fused_damped` reads: the fused pass's arguments and the legs
    kernel's, recorded."""

    BLOCK = 32

    def __init__(self, n, Je, Cq):
        self.n, self.Je, self.Cq = n, Je, Cq
        self.asked = {}

    def fused_arguments(self, x, y, z, pk, **options):
        self.asked["fused"] = (np.array([x, y, z]).T, pk, options)
        out = {"q": "q", "M": "M", "K_R": "K_R", "K_F": "K_F"}
        return out, self.n, "keep", "fused args"

    def kernel_arguments(self, name, pk, n):
        self.asked["legs"] = (name, pk, n)
        return ("legs", 0, 0, 0, {"Je": self.Je, "Cq": self.Cq})

    def address(self, name):
        return f"address of {name}"


@pytest.mark.parametrize("rigid", [False, True])
def test_fused_damped_hands_the_pass_and_the_legs_to_one_call(monkeypatch, rigid):
    from eigentwist.runtime import c_damped
    from eigentwist.runtime import damped as damped_module

    Je, Cq, M, K_ground = structure(4)
    kernels = Kernels(4, Je, Cq)
    got = {}

    def one_pass(fused, legs, block, n, q, M_, K, Je_, Cq_, e_used, B, k_d, c_d, t_d, rules, threads):
        got.update(locals())
        return "poles"

    monkeypatch.setattr(c_damped, "one_pass", one_pass)
    ev = StandIn(rigid=rigid)
    ev.kernels = kernels
    P = np.arange(12.0).reshape(4, 3)
    basis = np.eye(6, dtype=int)[:, 3:].tolist()  # read as doubles
    out, solved = dm.fused_damped(ev, ("servo_damping", "servo_delay"), P, params(), {"pk": 1}, True, basis, 5)
    assert ev.models == [("servo_damping", "servo_delay")]
    k = "K_R" if rigid else "K_F"
    poses, pk, options = kernels.asked["fused"]
    assert np.array_equal(poses, P) and pk == {"pk": 1}
    assert options == dict(
        matrices=("M", k), ik=("q",), model="rigid" if rigid else "flexible", vectors=True, normalize=True, status=True
    )
    assert kernels.asked["legs"] == ("legs", {"pk": 1}, 4)
    assert got["fused"] == ("address of fused", "fused args") and got["legs"] == ("legs", 0, 0, 0, {"Je": Je, "Cq": Cq})
    assert (got["block"], got["n"], got["q"], got["M_"], got["K"]) == (32, 4, "q", "M", k)
    assert got["Je_"] is Je and got["Cq_"] is Cq and got["e_used"] == (1 if rigid else JOINTS) and got["threads"] == 5
    assert (got["B"] is None) is not rigid
    assert not rigid or (np.array_equal(got["B"], np.eye(6)[:, 3:]) and got["B"].dtype == np.float64)
    assert np.array_equal(got["k_d"], np.full((4, LEGS), K_A)) and np.array_equal(got["c_d"], np.full((4, LEGS), C_A))
    assert np.array_equal(got["t_d"], np.full((4, LEGS), T_D))
    assert got["rules"] == (
        damped_module.RIGID,
        damped_module.ELIMINATE,
        damped_module.UNSTABLE_ZETA,
        damped_module.AMBIGUOUS,
    )
    assert out == {"q": "q", "M": "M", "K_R": "K_R", "K_F": "K_F"}
    assert solved == {"poles": "poles", "legs": {"Je": Je, "Cq": Cq}, "stiffness": k, "M": "M", "K": k}


def rotation6(seed=5):
    """An orthonormal 6x6 basis that is not symmetric (twists in turned coordinates)."""
    Q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(6, 6)))
    assert not np.allclose(Q, Q.T)
    return Q


def test_from_legs_keys_and_undecided_poses_in_other_coordinates(driver):
    """Poses whose legs agree but whose model stiffness differs are two problems; the undecided
    ones are solved on the driver's coordinates B (turned twists: the same poles), with the legs'
    springs alone where neither a model stiffness nor a ground is given; the driver reads doubles."""
    Je2, Cq2, M, K_ground, K_F, _, _ = flexible_case(invalid=None, n_rows=2)
    Je, Cq = Je2[[0, 0]], Cq2[[0, 0]]
    K_model = np.stack([K_F[0], K_F[0] + np.diag([40.0, 0, 0, 0, 0, 4.0])])
    Q = rotation6()
    k_d, c_d = np.full((2, LEGS), K_A), np.full((2, LEGS), C_A)
    t_d = np.zeros((2, LEGS), dtype=int)
    driver.decide = lambda n: np.zeros(n, dtype=bool)
    d = dm._from_legs(M[None], K_model, None, Je, Cq, np.broadcast_to(Q, (2, 6, 6)), k_d, c_d, t_d, 1)
    (call,) = driver.calls
    assert len(call["Je"]) == 2 and call["t_d"].dtype == np.float64
    for k in range(2):
        check_poles(
            d, np.eye(2, dtype=bool)[k], lambda _: lambda s: dynamic(s, 0, Je, Cq, M, K_model[k], np.eye(6), t_d=0.0)
        )
    # neither a model stiffness nor a ground: the legs' springs J_e^T C_q^+ J_e alone
    K_legs = K_F[0] - K_ground
    d = dm._from_legs(M[None], None, None, Je[:1], Cq[:1], Q[None], k_d[:1], c_d[:1], t_d[:1], 1)
    check_poles(d, np.array([True]), lambda _: lambda s: dynamic(s, 0, Je, Cq, M, K_legs, np.eye(6), t_d=0.0))
    # five turned twists (a rigid direction's complement): the poles of the problem on them
    B5 = Q[:, :5]
    d = dm._from_legs(M[None], K_F[:1], None, Je[:1], Cq[:1], B5[None], k_d[:1], c_d[:1], t_d[:1], 1)
    check_poles(d, np.array([True]), lambda _: lambda s: dynamic(s, 0, Je, Cq, M, K_F[0], B5, t_d=0.0))


def test_shared_reads_doubles():
    assert dm._shared(np.ones((1, 2, 2), dtype=int), 1).dtype == np.float64


def test_pass_damping_of_two_poses():
    """Two poses, the second undecided: the pass's per-pose arrays are taken at that pose."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=2)
    s, *_ = made_up(6)
    poles = np.broadcast_to(s, (2, 6)).copy()
    solved = {
        "poles": (np.abs(poles), np.ones((2, 6)), poles.imag, poles, np.ones(2, dtype=bool), np.array([False, True])),
        "legs": {"Je": Je, "Cq": Cq, "K_ground": K_ground},
        "stiffness": "K_F",
        "M": np.broadcast_to(M, (2, 6, 6)),
        "K": K_F,
    }
    modes = NS(freq_hz=freq, valid=None, stable=np.ones(2, dtype=bool), eigentwists=None)
    d = dm.pass_damping(StandIn(), ("servo_damping",), np.zeros((2, 3)), {}, params(), solved, modes)
    assert np.allclose(d.poles[0], s)
    check_poles(d, np.array([False, True]), lambda _: lambda s: dynamic(s, 1, Je, Cq, M, K_F[1], np.eye(6), t_d=0.0))


def test_coupled_body_with_a_loss_factor():
    """The hysteretic passive compliance on a coupled body's leg too (the actuator's own 1/k_d not)."""
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    g = np.array([0.1, 0.0, -0.2, 1.0, 0.3, 0.0])
    k_c = 5e3
    ev = StandIn(couplings=[NS(body="arm", effect="arm_coupling")], bodies=["platform", "arm", "arm"])
    T = [np.eye(6, 7), np.hstack([np.eye(6), -g[:, None]]), np.hstack([np.eye(6), -g[:, None]])]

    def D(k):
        def f(s):
            Dx = np.zeros((7, 7), dtype=complex)
            Dx[:6, :6] = s * s * M + K_ground
            Dx[6, 6] = k_c
            for i in range(LEGS):
                Dx += T[i].T @ leg_stiffness(Je[k, i], Cq[k, i], s, C_A, T_D, loss=0.05) @ T[i]
            return Dx

        return f

    inp = inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_F": K_F}, p=params(eta_s=0.05))
    inp["legs"].update({"G_c": g[None, :, None], "K_c": np.array([[k_c]])})
    effects = ("servo_damping", "servo_delay", "arm_coupling", "structural_loss")
    d = dm.damped_of(ev, effects, inp, modes_of(freq), False)
    check_poles(d, rows, D, m=6)


def test_a_light_platform_keeps_its_massive_coordinates():
    """Inertia of a few grams (1e-6 of the case's): every platform coordinate stays massive; the
    threshold is relative to the largest (1e-12 of it), not absolute."""
    Je, Cq, M, K_ground = structure(1)
    g = np.array([0.1, 0.0, -0.2, 1.0, 0.3, 0.0])[:, None]
    K_x = np.zeros((1, 7, 7))
    K_x[:, :6, :6] = K_ground
    K_x[:, 6, 6] = 5e3
    T = [np.eye(6, 7)[None], np.hstack([np.eye(6), -g])[None], np.eye(6, 7)[None]]
    light = 1e-6 * M
    Mr, K, W, h, G, P = dm._coupled_reduction(Je, Cq, np.full((1, LEGS), K_A), light[None], None, T, K_x, condense)
    assert Mr.shape == (1, 6, 6) and np.allclose(np.sort(np.diag(Mr[0])), np.sort(np.linalg.eigvalsh(light)), rtol=1e-9)


def test_coupled_body_under_a_gravity_preload(monkeypatch):
    """The preload's stiffness (a stand-in) on the platform's twist t, with a leg on a coupled body."""
    K_G6 = np.diag([-20.0, -30.0, 5.0, -1.0, 2.0, -3.0])
    monkeypatch.setattr(gravity, "gravity_stiffness", lambda *a, **k: np.broadcast_to(K_G6, (1, 6, 6)))
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(invalid=None, n_rows=1)
    g = np.array([0.1, 0.0, -0.2, 1.0, 0.3, 0.0])
    ev = StandIn(couplings=[NS(body="arm", effect="arm_coupling")], bodies=["platform", "arm", "platform"])
    T = [np.eye(6, 7), np.hstack([np.eye(6), -g[:, None]]), np.eye(6, 7)]

    def D(k):
        def f(s):
            Dx = np.zeros((7, 7), dtype=complex)
            Dx[:6, :6] = s * s * M + K_ground + K_G6
            Dx[6, 6] = 5e3
            for i in range(LEGS):
                Dx += T[i].T @ leg_stiffness(Je[k, i], Cq[k, i], s, C_A, 0.0) @ T[i]
            return Dx

        return f

    inp = inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_R": K_F, "K_F": K_F}, preloaded=True)
    inp["legs"].update({"G_c": g[None, :, None], "K_c": np.array([[5e3]])})
    d = dm.damped_of(ev, ("servo_damping", "arm_coupling"), inp, modes_of(freq), False)
    check_poles(d, rows, D, m=6)


def test_rigid_model_with_a_loss_factor():
    """The rigid model's actuated joints, hysteretic: each leg's a a^T / c(s) with
    c(s) = (c_0 - 1/k_d) / (1 + i eta_s) + 1/Z(s); K_R = sum a a^T / c_0 (Eq. 14), no ground."""
    Je, Cq, M, K_ground = structure(2)
    basis = np.eye(6)[:, 3:]
    a, c0 = Je[:, :, 0, :], Cq[:, :, 0, 0]
    K_R = np.einsum("nl,nli,nlj->nij", 1.0 / c0, a, a)
    rows = np.array([True, True])
    freq = np.array([undamped_hz(basis.T @ K @ basis, basis.T @ M @ basis) for K in K_R])
    inp = inputs_of(rows, Je, Cq, M, K_ground, {"M": M, "K_R": K_R}, p=params(eta_s=0.05))
    d = dm.damped_of(StandIn(rigid=True, basis=basis), ("servo_damping", "structural_loss"), inp, modes_of(freq), False)

    def D(k):
        def f(s):
            c = (c0[k] - 1 / K_A) / (1 + 0.05j) + 1.0 / (K_A + C_A * s)
            K = sum(np.outer(a[k, i], a[k, i]) / c[i] for i in range(LEGS))
            return basis.T @ (s * s * M + K) @ basis

        return f

    check_poles(d, rows, D)


def test_preload_on_the_admissible_twists(monkeypatch):
    """A rigid passive joint and a gravity preload (a stand-in): B^T K_G B added on the five twists."""
    K_G6 = np.diag([-20.0, -30.0, 5.0, -1.0, 2.0, -3.0])
    K_G6[0, 5] = K_G6[5, 0] = 2.0
    monkeypatch.setattr(gravity, "gravity_stiffness", lambda *a, **k: np.broadcast_to(K_G6, (2, 6, 6)))
    Je, Cq, M, K_ground, K_F, rows, freq = flexible_case(rigid_joint=True, invalid=None, n_rows=2)
    rigid_row = Je[:, 2, 1, :]
    Bs = [scipy.linalg.null_space(rigid_row[k][None, :]) for k in range(2)]
    mats = {"M": M, "K_R": K_F, "K_F": K_F}
    d = dm.damped_of(
        StandIn(), ("servo_damping",), inputs_of(rows, Je, Cq, M, K_ground, mats, preloaded=True), modes_of(freq), True
    )
    check_poles(d, rows, lambda k: lambda s: dynamic(s, k, Je, Cq, M, K_F[k] + K_G6, Bs[k], t_d=0.0))
    # without the model's eigentwists the columns beyond the five twists are NaN
    assert (
        d.shapes.shape == (2, 6, 6) and np.all(np.isnan(d.shapes[:, :, 5])) and not np.any(np.isnan(d.shapes[:, :, :5]))
    )
