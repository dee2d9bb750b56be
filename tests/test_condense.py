"""Rigid constraints condensed exactly (runtime/condense.py).

Expectations: the rigid model on the allowed twists (the 3x3 subsets of M and K_R),
independent of the condensation's own null-space basis; the limit of a structure
whose compliance goes to zero; a hand-made two-spring example; the penalty model of the
paper (c_rigid = 1e-12) within its penalty error.
"""

import numpy as np
import pytest

import eigentwist
from eigentwist.runtime.condense import (
    compliance_eigh,
    condensed_compliance,
    finite_modes,
    leg_joints,
    platform_compliance,
)
from eigentwist.runtime.eigen import frequencies_hz, generalized_eigh


@pytest.fixture(scope="module", params=["heli4", "delta"])
def case(request):
    ev = eigentwist.load(request.param, backend="numpy")
    ref = np.array(ev.robot.x_ref, dtype=float)
    poses = np.array([ref, ref + [0.05, -0.03, 0.02], ref + [-0.04, 0.06, -0.03]])
    return ev, poses


def test_rigid_six_by_six_equals_allowed_twist_subsets(case):
    ev, poses = case
    C, M = platform_compliance(ev, poses, "rigid")
    f, V = compliance_eigh(C, M)
    assert np.isinf(f[:, 3:]).all()  # the constrained directions: infinite frequency
    np.testing.assert_allclose(finite_modes(f), ev.frequencies(poses, "rigid"), rtol=1e-10, atol=0)
    # eigentwists are M-orthonormal; the finite ones lie in the allowed twists (three translations)
    np.testing.assert_allclose(np.swapaxes(V, 1, 2) @ M @ V, np.broadcast_to(np.eye(6), (3, 6, 6)), atol=1e-9)
    assert np.abs(V[:, :3, :3]).max() < 1e-12 * np.abs(V[:, 3:, :3]).max()


def test_vanishing_structure_tends_to_the_rigid_model(case):
    """A structural compliance scaled by s -> 0 (infinite structural stiffness) gives the
    rigid model's frequencies, with an error proportional to s."""
    ev, poses = case
    Je, Cq, _, _ = leg_joints(ev, poses, "paper")
    Je_r, Cq_r, Kp, M = leg_joints(ev, poses, "actuator_loss")  # rigid: the actuators only
    np.testing.assert_array_equal(Je, Je_r)
    rigid = ev.frequencies(poses, "actuator_loss")
    errs = []
    for s in (1e-3, 1e-4, 0.0):
        C, _ = condensed_compliance(Je, Cq_r + s * (Cq - Cq_r), Kp)
        f = finite_modes(compliance_eigh(C, M)[0])[:, :3]
        errs.append(np.abs(f / rigid - 1).max())
    assert errs[-1] < 1e-10
    assert 5 < errs[0] / errs[1] < 20  # first order in the structural compliance


def test_two_springs_and_a_rigid_link_by_hand():
    """A unit mass on two orthogonal springs k1, k2 (x, y) and a rigid link in z."""
    k1, k2 = 4.0e4, 9.0e4
    Je = np.zeros((1, 3, 1, 6))
    Je[0, 0, 0, 3], Je[0, 1, 0, 4], Je[0, 2, 0, 5] = 1.0, 1.0, 1.0
    Cq = np.array([1 / k1, 1 / k2, 0.0]).reshape(1, 3, 1, 1)
    Kp = np.zeros((1, 6, 6))
    Kp[0, :3, :3] = np.diag([1.0e3, 2.0e3, 3.0e3])  # rotational springs in parallel
    M = np.eye(6)[None]
    C, B = condensed_compliance(Je, Cq, Kp)
    f, _ = compliance_eigh(C, M)
    expected = np.sqrt([1.0e3, 2.0e3, 3.0e3, k1, k2]) / (2 * np.pi)
    np.testing.assert_allclose(f[0, :5], expected, rtol=1e-13)
    assert f[0, 5] == np.inf and B.shape == (1, 6, 5)


def penalty_rtol(K, M, C, n):
    """(N, n): how far, relative, the finite frequencies of the penalty model (K_F, M) may be
    from the exact compliance C's, from the problem's conditioning (no CPU-specific margin).

    * The penalty: K_F⁻¹ = C + ΔC. Weyl's inequality bounds the move of every sorted
      eigenvalue μ of Lᵀ C L (M = L Lᵀ, μ = 1/ω²) by ‖Lᵀ ΔC L‖₂; it holds for each member
      of a degenerate cluster too (the Delta's two equal lateral modes, which the penalty
      splits): the cluster is compared as a sorted set, its members one by one.
    * Round-off: a backward-stable solve of (K_F, M) moves each eigenvalue λ by a few
      ε λ_max (6 ε here, n = 6): relative, 6 ε λ_max/λ_i, where λ_max is the penalty's stiff
      direction (~1/c_rigid): the penalty times the condition number.

    A frequency's relative error is half its eigenvalue's.
    """
    lam = generalized_eigh(K, M)[0]
    L = np.linalg.cholesky(M)
    dC = np.linalg.inv(K) - C
    weyl = np.linalg.norm(np.swapaxes(L, 1, 2) @ dC @ L, 2, axis=(1, 2))[:, None]
    mu = 1.0 / lam[:, :n]
    eps = np.finfo(float).eps
    return 0.5 * (weyl / mu + 6 * eps * lam[:, -1:] / lam[:, :n])


def test_penalty_model_within_its_penalty(case):
    """The generated K_F (c_rigid = 1e-12 rad/(N m)) agrees with the exact model to its
    penalty error and round-off (:func:`penalty_rtol`), on every finite mode."""
    ev, poses = case
    for model in ("rigid", "paper"):
        C, M = platform_compliance(ev, poses, model)
        f = compliance_eigh(C, M)[0]
        K = ev.matrices(poses, model)["K_F"]
        fp = frequencies_hz(generalized_eigh(K, M)[0])
        n = int(np.isfinite(f[0]).sum())
        rtol = penalty_rtol(K, M, C, n)
        assert (np.abs(fp[:, :n] - f[:, :n]) <= rtol * f[:, :n]).all(), np.abs(fp[:, :n] / f[:, :n] - 1) / rtol
        assert rtol.max() < 1e-3  # the bound still bites: far below a wrong model's error
        assert (fp[:, n:] > 1e5).all()  # the penalty's stiff directions: ~1e6 Hz


def test_penalty_rtol_is_the_conditioning():
    """The bound of a diagonal penalty by hand: two finite modes (k = 1, 4 N/m, unit masses)
    and a stiff one (1/c = 1e12): Weyl's term is the penalty itself (c = 1e-12, negligible),
    the round-off term 6 eps 1e12 / k_i / 2."""
    K = np.diag([1.0, 4.0, 1e12])[None]
    M = np.eye(3)[None]
    C = np.diag([1.0, 0.25, 0.0])[None]
    eps = np.finfo(float).eps
    np.testing.assert_allclose(penalty_rtol(K, M, C, 2), [[3 * eps * 1e12, 3 * eps * 1e12 / 4]], rtol=1e-3)
    C_off = np.diag([1.0 + 1e-6, 0.25, 0.0])[None]  # an exact model 1e-6 off: Weyl's term sees it
    assert penalty_rtol(K, M, C_off, 2)[0, 0] >= 0.5e-6


def test_exact_model_is_well_conditioned():
    """The solved matrix's condition number is the squared ratio of the finite modes'
    frequencies (the physics), not the penalty's ~1e8 (Heli4 at x_ref)."""
    ev = eigentwist.load("heli4", backend="numpy")
    x = np.array([ev.robot.x_ref], dtype=float)
    for model in ("rigid", "actuator_loss,ee_compliance"):
        C, M = platform_compliance(ev, x, model)
        f = finite_modes(compliance_eigh(C, M)[0])
        L = np.linalg.cholesky(M)
        mu = np.linalg.eigvalsh(np.swapaxes(L, 1, 2) @ C @ L)[0, 6 - f.shape[1] :]
        np.testing.assert_allclose(mu.max() / mu.min(), (f.max() / f.min()) ** 2, rtol=1e-9)
        assert mu.max() / mu.min() < 10
        assert np.linalg.cond(ev.matrices(x, model)["K_F"][0]) > 1e7  # the penalty route's


def test_coupled_platform_bodies_condensed_exactly():
    """Legs on plates coupled to the tool (``ee_coupling``): the exact route's
    finite modes equal the penalty K_F's (which condenses the coupling in closed form) to
    its penalty error, and a coupling 1e6 times stiffer gives the uncoupled model."""
    ev = eigentwist.load("heli4", backend="numpy")
    x = np.array([ev.robot.x_ref, np.add(ev.robot.x_ref, [0.04, -0.03, 0.02])])
    C, M = platform_compliance(ev, x, "ee_coupling")
    f = finite_modes(compliance_eigh(C, M)[0])
    assert f.shape == (2, 3)  # the legs' rotations stay rigid
    mats = ev.matrices(x, "ee_coupling")
    penalty = frequencies_hz(generalized_eigh(mats["K_F"], mats["M"])[0])[:, :3]
    assert (np.abs(penalty - f) <= penalty_rtol(mats["K_F"], mats["M"], C, 3) * f).all()
    stiff = {k: 1e6 * next(q.default for q in ev.robot.parameters if q.name == k) for k in ("k_E_rot", "k_E_lin")}
    C, M = platform_compliance(ev, x, "ee_coupling", **stiff)
    bare = ev.frequencies(x, "rigid", eta_a=1.0)  # the actuators alone (rigid: eta_a 0.82)
    np.testing.assert_allclose(finite_modes(compliance_eigh(C, M)[0]), bare, rtol=1e-5)
    np.testing.assert_allclose(ev.frequencies(x, "ee_coupling")[:, :3], f, rtol=1e-12)  # the default route


def test_default_route_is_exact():
    """``frequencies`` of a flexible model with rigid constraint directions: the finite modes
    are the exact condensation's (no c_rigid), so the rigid limit is reached to round-off:
    the end-effector compliance alone, 1e9 times stiffer, gives the rigid model to 1e-8
    (the penalty route: 1e-7 at best, its c_rigid error), and a c_rigid of the user's is
    a finite constraint compliance (K_F as given)."""
    ev = eigentwist.load("heli4", backend="numpy")
    x = np.array([ev.robot.x_ref, np.add(ev.robot.x_ref, [0.04, -0.03, 0.02])])
    stiff = {k: 1e9 * next(q.default for q in ev.robot.parameters if q.name == k) for k in ("k_E_rot", "k_E_lin")}
    f = ev.frequencies(x, "actuator_loss,ee_compliance", **stiff)
    np.testing.assert_allclose(f[:, :3], ev.frequencies(x, "actuator_loss"), rtol=1e-8)
    assert (f[:, 3:] > 1e5).all()  # the rigid directions' stand-ins
    mats = ev.matrices(x, "actuator_loss,ee_compliance", **stiff)
    penalty = frequencies_hz(generalized_eigh(mats["K_F"], mats["M"])[0])[:, :3]
    assert np.abs(penalty / ev.frequencies(x, "actuator_loss") - 1).max() > 1e-7
    given = ev.frequencies(x, "actuator_loss,ee_compliance", c_rigid=1e-9, **stiff)
    mats = ev.matrices(x, "actuator_loss,ee_compliance", c_rigid=1e-9, **stiff)
    np.testing.assert_allclose(given, frequencies_hz(generalized_eigh(mats["K_F"], mats["M"])[0]), rtol=1e-12)


@pytest.mark.parametrize("robot", ["heli4", "delta"])
def test_matrices_json_exact_route(robot, capsys):
    """``matrices --model rigid --json``: the 6x6 route (C_F, M) gives the rigid model's
    frequencies (3x3 allowed-twist subsets) to 1e-10, the constrained directions null."""
    import json

    from eigentwist.cli.main import main

    assert main(["matrices", "--robot", robot, "--model", "rigid", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["freq_exact_hz"][3:] == [None] * 3
    np.testing.assert_allclose(d["freq_exact_hz"][:3], d["freq_hz"], rtol=1e-10, atol=0)
    C, M = np.array(d["C_F"]), np.array(d["M"])
    np.testing.assert_allclose(finite_modes(compliance_eigh(C[None], M[None])[0])[0], d["freq_rigid_hz"], rtol=1e-10)
    assert main(["matrices", "--robot", robot, "--model", "paper", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(d["freq_exact_hz"], d["freq_hz"], rtol=1e-6)  # K_F's penalty: ~1e-8 here


@pytest.mark.derives
def test_paper_fit_does_not_depend_on_the_jacobian_kind():
    """The paper data's final model (actuator_loss, ee_compliance) fitted with central
    differences and with the generated sensitivities: the same k_E_rot, k_E_lin to 1e-5
    (with K_F's penalty they differed by 5e-4 and 1.5e-3: round-off of a 1e12..1e4 matrix)."""
    import importlib

    from eigentwist.diagnose import paper_measurements

    fit = importlib.import_module("eigentwist.diagnose.fit").fit
    ev = eigentwist.load("heli4", backend="numpy")  # the Jacobian kinds under test, not the backend
    meas = paper_measurements()
    got = {
        kind: fit(meas, ("actuator_loss", "ee_compliance"), ev, ("k_E_rot", "k_E_lin"), jacobian=kind)
        for kind in ("differences", "exact")
    }
    assert got["exact"].jacobian == "exact"
    for name in ("k_E_rot", "k_E_lin"):
        assert got["differences"].values[name] == pytest.approx(got["exact"].values[name], rel=1e-5)


def test_rigid_constraint_modes_are_marked_and_never_proposed():
    """A rigid direction's column (an infinite frequency; K_F's stand-in value) is marked in
    ``Modes.constrained``; models without one have None. The separating measurement between
    two fitted models never names such a mode (it cannot be measured)."""
    import importlib

    from eigentwist.diagnose import paper_measurements
    from eigentwist.diagnose.separate import next_measurement

    fit = importlib.import_module("eigentwist.diagnose.fit").fit
    ev = eigentwist.load("heli4", backend="numpy")
    x = np.array([ev.robot.x_ref, np.add(ev.robot.x_ref, [0.04, -0.03, 0.02])])
    m = ev.modes(x, "actuator_loss,ee_compliance")
    assert m.constrained is not None and m.constrained.sum(axis=1).tolist() == [3, 3]
    assert (m.freq_hz[m.constrained] > 1e5).all() and (m.freq_hz[~m.constrained] < 1e3).all()
    assert ev.modes(x, "paper").constrained is None
    meas = paper_measurements(ev)
    fits = [
        fit(meas, ("actuator_loss", extra), ev, ("k_E_rot", "k_E_lin")) for extra in ("ee_compliance", "ee_coupling")
    ]
    out = next_measurement(ev, meas, *fits)
    assert out is not None and max(out["predicted_hz"].values()) < 1e4
