"""The gallery (examples/robots/) and the planar and lower-mobility pose spaces: physics identities.

Expectations come from physics (symmetry and definiteness of M and K, f ~ sqrt(k_a), the
robots' threefold symmetry, the allowed twists annihilated by the constraint wrenches) and
from an independent computation: the kinetic energy of the bodies from finite differences
of their points (the description's closed-form geometry, evaluated numerically), against
1/2 t^T M t of the derived M.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import eigentwist
from eigentwist.description.pose import FULL, POSE, ROTATION, twist_order
from eigentwist.runtime.allowed import allowed_twists, constraint_positions, coordinate_twists
from eigentwist.runtime.errors import UnreachablePoseError
from eigentwist.runtime.poses import rotation_matrix

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"
NAMES = ("prs3", "rrr3", "linear_delta", "upu3", "rus6")
CONSTRAINED = ("prs3", "rrr3", "linear_delta", "upu3")


def _module(name):
    spec = importlib.util.spec_from_file_location(f"gallery_{name}", GALLERY / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session")
def gallery():
    """The gallery's evaluators (generated once into the session's cache, NumPy backend)."""
    return {name: eigentwist.load(str(GALLERY / f"{name}.py"), backend="numpy", progress=None) for name in NAMES}


def _on(gallery, name, backend):
    """The gallery robot ``name`` on ``backend``: the session's NumPy evaluator, or its C one
    (one thread)."""
    if backend == "numpy":
        return gallery[name]
    return eigentwist.load(str(GALLERY / f"{name}.py"), backend="c", threads=1, progress=None)


def _poses(ev, n, seed=1):
    box = np.array(ev.robot.workspace)
    poses = box[:, 0] + (box[:, 1] - box[:, 0]) * np.random.default_rng(seed).random((n, len(box)))
    return poses[ev.valid(poses, "rigid")]


@pytest.mark.parametrize("name", NAMES)
def test_inertia_definite_stiffness_semidefinite(gallery, name):
    ev = gallery[name]
    x = _poses(ev, 30)
    assert len(x) >= 20
    mats = ev.matrices(x, "rigid")
    for k in ("M", "K_R", "K_F"):
        np.testing.assert_allclose(mats[k], np.swapaxes(mats[k], 1, 2), rtol=0, atol=1e-9 * np.abs(mats[k]).max())
    assert (np.linalg.eigvalsh(mats["M"]) > 0).all()
    lam = np.linalg.eigvalsh(mats["K_R"])
    assert (lam > -1e-9 * lam.max(axis=1, keepdims=True)).all()
    M, K = ev.stiffness(x, "rigid")
    n = len(ev.pose_names)
    assert (
        M.shape == K.shape == (len(x), n, n) and (np.linalg.eigvalsh(M) > 0).all() and (np.linalg.eigvalsh(K) > 0).all()
    )


@pytest.mark.parametrize("name", NAMES)
def test_rigid_frequencies_scale_with_root_of_actuator_stiffness(gallery, name):
    ev = gallery[name]
    x = _poses(ev, 10)
    k = ev.robot.parameter("k_a").default
    np.testing.assert_allclose(ev.frequencies(x, "rigid", k_a=4 * k), 2 * ev.frequencies(x, "rigid", k_a=k), rtol=1e-10)


@pytest.mark.parametrize("name", NAMES)
def test_threefold_symmetry_at_home_gives_double_frequencies(gallery, name):
    """Legs 120 deg apart: at home the modes in the base plane come in equal pairs (the two
    horizontal translations of a Delta, 3-RRR or 3-UPU, the two tilts of a 3-PRS; two
    pairs of the 6-RUS), the vertical and the spin modes are single: with n modes,
    n // 3 pairs equal to 1e-9 and the others apart."""
    f = gallery[name].frequencies(np.array([gallery[name].robot.x_ref]), "rigid")[0]
    gaps = np.diff(f) / f[1:]
    assert np.sum(gaps < 1e-9) == len(f) // 3
    assert np.sum(gaps > 1e-3) == len(f) - 1 - len(f) // 3


def _constraint_rows(ev, x):
    rows = ev.jacobians(x)["J_rows"]
    return np.stack([rows[:, i, r] for i, leg in enumerate(ev.robot.legs) for r in constraint_positions(leg)], axis=1)


@pytest.mark.parametrize("name", CONSTRAINED)
def test_allowed_twists_are_annihilated_by_the_constraint_wrenches(gallery, name):
    ev = gallery[name]
    x = _poses(ev, 20)
    B = ev.allowed_twists(x)
    A = _constraint_rows(ev, x)
    assert np.abs(A @ B).max() < 1e-12 * np.abs(A).max()
    np.testing.assert_allclose(np.swapaxes(B, 1, 2) @ B, np.broadcast_to(np.eye(3), (len(x), 3, 3)), atol=1e-12)
    assert np.linalg.matrix_rank(A[0], tol=1e-9) == 3  # three independent constraints


@pytest.mark.parametrize("name", ("heli4", "delta", "hexapod", "linear_delta", "upu3", "rus6"))
def test_fixed_subsets_are_the_rule(gallery, name):
    """The Heli4's and Delta's 3x3 translational subsets (and the hexapod's full 6x6) are
    the rule's special case: the null space of their constraint wrenches, to the round-off of
    the generated constraint rows (their zeros at home are sums that cancel to ~1e-17)."""
    ev = gallery[name] if name in gallery else eigentwist.load(name, backend="numpy")
    x = np.array(ev.robot.x_ref) + 0.01 * np.random.default_rng(2).standard_normal((8, len(ev.robot.x_ref)))
    rows = _constraint_rows(ev, x) if any(constraint_positions(leg) for leg in ev.robot.legs) else np.zeros((8, 0, 6))
    B = allowed_twists(rows, coordinate_twists(twist_order(ev.robot.pose)))
    np.testing.assert_allclose(B, ev.allowed_twists(x), rtol=0, atol=1e-14)
    home = np.array([ev.robot.x_ref])
    rows = _constraint_rows(ev, home) if rows.shape[1] else np.zeros((1, 0, 6))
    np.testing.assert_allclose(
        allowed_twists(rows, coordinate_twists(twist_order(ev.robot.pose))), ev.allowed_twists(home), rtol=0, atol=1e-15
    )


def test_followers_meet_the_closures_and_turn_the_basis(gallery):
    """3-PRS: the completed pose keeps every spherical joint in its leg's plane (a few lines
    of NumPy), x, y, rot_z move with the tilt, and the allowed twists turn with the pose."""
    ev = gallery["prs3"]
    x = np.array([[0.60, 0.0, 0.0], [0.58, 0.1, -0.05], [0.62, -0.12, 0.12]])
    full = np.asarray(ev.completion.poses(x))
    R = rotation_matrix(full[:, 3:])
    for deg in (90, 210, 330):
        a = np.radians(deg)
        top = full[:, :3] + R @ (0.15 * np.array([np.cos(a), np.sin(a), 0.0]))
        assert np.abs(top @ np.array([-np.sin(a), np.cos(a), 0.0])).max() < 1e-12
    np.testing.assert_array_equal(full[:, [2, 3, 4]], x)
    assert np.abs(full[1:, :2]).max() > 1e-4 and np.abs(full[0, [0, 1, 5]]).max() < 1e-15
    B = ev.allowed_twists(x)
    assert np.abs(B[1] - B[0]).max() > 1e-3


def test_unreachable_commanded_pose_is_one_line(gallery, monkeypatch):
    ev = gallery["prs3"]
    with pytest.raises(UnreachablePoseError, match="unreachable for leg 1: the leg cannot span") as err:
        ev.frequencies(np.array([[0.60, 2.5, 0.0]]), "rigid")
    assert "\n" not in str(err.value)
    m = ev.modes(np.array([[0.60, 0.0, 0.0], [0.60, 2.5, 0.0]]), "rigid", invalid="nan")
    assert m.valid.tolist() == [True, False] and np.isnan(m.freq_hz[1]).all()
    from eigentwist.runtime import platform

    monkeypatch.setattr(platform, "MAX_STEPS", 1)  # Newton cannot converge in one step
    with pytest.raises(UnreachablePoseError) as err:
        ev.frequencies(np.array([[0.60, 0.1, -0.1]]), "rigid")
    assert "\n" not in str(err.value) and "rot_x = 0.1" in str(err.value) and "did not converge" in str(err.value)
    m = ev.modes(np.array([[0.60, 0.0, 0.0], [0.60, 0.1, -0.1]]), "rigid", invalid="nan")
    assert m.valid.tolist() == [True, False]


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.compiled)])
def test_a_lower_mobility_batch_with_an_unreachable_pose_keeps_the_others(gallery, backend):
    """The 3-PRS's rigid model over a batch with an unreachable pose (``invalid="nan"``): the
    model's three coordinates in twist order [omega; v] (z, rot_x, rot_y: rx, ry, z), the pose
    NaN and invalid, the others' modes those of a batch without it (each pose solved on its
    own; C's Jacobi sweeps a block until all its poses converge: round-off), stable; without
    eigentwists the same frequencies."""
    ev = _on(gallery, "prs3", backend)
    x = np.array([[0.60, 0.0, 0.0], [0.60, 2.5, 0.0], [0.58, 0.05, -0.03]])
    m = ev.modes(x, "rigid", invalid="nan")
    alone = ev.modes(x[[0, 2]], "rigid")
    assert m.stiffness_model == alone.stiffness_model == "rigid" and m.axes == alone.axes == ("rx", "ry", "z")
    assert m.freq_hz.shape == (3, 3) and m.eigentwists.shape == (3, 3, 3)
    assert m.valid.tolist() == [True, False, True] and m.stable.tolist() == [True, True, True]
    assert np.isnan(m.freq_hz[1]).all() and np.isnan(m.eigentwists[1]).all()
    assert m.freq_hz[[0, 2]] == pytest.approx(alone.freq_hz, rel=1e-12)
    assert m.eigentwists[[0, 2]] == pytest.approx(alone.eigentwists, abs=1e-9)
    bare = ev.modes(x, "rigid", invalid="nan", vectors=False)
    assert bare.eigentwists is None and np.array_equal(bare.freq_hz, m.freq_hz, equal_nan=True)
    for invalid in ("raise", "nan"):  # every pose reachable
        every = ev.modes(x[[0, 2]], "rigid", invalid=invalid, vectors=False)
        assert every.eigentwists is None and every.axes == ("rx", "ry", "z") and every.stiffness_model == "rigid"
        assert np.array_equal(every.freq_hz, alone.freq_hz) and every.stable.tolist() == [True, True]
        assert every.valid is None if invalid == "raise" else every.valid.tolist() == [True, True]


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.compiled)])
def test_a_lower_mobility_rigid_model_with_a_parameter_given_is_its_reduced_pencil(gallery, backend):
    """The 3-PRS's rigid frequencies with the platform radius R_p given (its followers x, y
    move with it): those of B^T K_R B, B^T M B from the public matrices and allowed twists at
    that value (SciPy's solver here), and not those of the default radius."""
    import scipy.linalg

    ev = _on(gallery, "prs3", backend)
    x = np.array([[0.60, 0.02, -0.03], [0.58, 0.05, -0.03], [0.62, -0.04, 0.01]])
    mats, B = ev.matrices(x, "rigid", R_p=0.2), ev.allowed_twists(x, R_p=0.2)
    want = [
        np.sqrt(scipy.linalg.eigh(b.T @ K @ b, b.T @ M @ b, eigvals_only=True)) / (2 * np.pi)
        for b, K, M in zip(B, mats["K_R"], mats["M"])
    ]
    assert ev.frequencies(x, "rigid", R_p=0.2) == pytest.approx(np.array(want), rel=1e-12)
    assert np.abs(ev.frequencies(x, "rigid") / want - 1).max() > 1e-3
    M_r, K_r = ev.stiffness(x, "rigid", R_p=0.2)  # the pair itself, from the user's poses
    reduced = np.swapaxes(B, 1, 2)
    assert M_r == pytest.approx(reduced @ mats["M"] @ B, rel=1e-12, abs=1e-12 * np.abs(M_r).max())
    assert K_r == pytest.approx(reduced @ mats["K_R"] @ B, rel=1e-12, abs=1e-12 * np.abs(K_r).max())


# -------------------------------------------------- kinetic energy, independently
def _points(ev, bodies, values):
    """A NumPy function of (full pose, parameters) -> each leg's body points, from the
    description's geometry (its input data), evaluated numerically."""
    p = {q.name: q.symbol for q in ev.robot.parameters}
    R = ROTATION
    names = sorted({k for _, ends in bodies for k in ends})
    exprs = [[leg.geometry(sp.Matrix(POSE), R, p)[k] for k in names] for leg in ev.robot.legs]
    f = sp.lambdify(list(POSE) + list(R) + list(p.values()), exprs, "numpy")
    values = [values[q.name] for q in ev.robot.parameters]

    def at(full):
        Rn = rotation_matrix(full[3:])
        out = f(*full[:3], *Rn.reshape(-1), *values)
        return [{k: np.asarray(v, dtype=float).reshape(-1) for k, v in zip(names, leg)} for leg in out]

    return at


def _energy(ev, full, dfull, bodies, platform, d):
    """Kinetic energy (J) along d(full)/dt from central differences of the points: point
    masses and slender uniform rods (m/6 (v1^2 + v1.v2 + v2^2)), plus the platform's."""
    at, h = _points(ev, bodies, d), 1e-6
    plus, minus = at(full + h * dfull), at(full - h * dfull)
    T = 0.0
    for leg_p, leg_m in zip(plus, minus):
        for mass, ends in bodies:
            v = [(leg_p[k] - leg_m[k]) / (2 * h) for k in ends]
            T += d[mass] / 2 * v[0] @ v[0] if len(v) == 1 else d[mass] / 6 * (v[0] @ v[0] + v[0] @ v[1] + v[1] @ v[1])
    Rp, Rm = rotation_matrix(full[3:] + h * dfull[3:]), rotation_matrix(full[3:] - h * dfull[3:])
    W = (Rp - Rm) / (2 * h) @ rotation_matrix(full[3:]).T
    omega, v = np.array([W[2, 1], W[0, 2], W[1, 0]]), dfull[:3]
    return T + platform(d, omega, v), np.concatenate([omega, v])


def PLATE(d, w, v):
    return d["m_pl"] / 2 * v @ v + 0.5 * (d["I_pl_xx"] * (w[0] ** 2 + w[1] ** 2) + d["I_pl_zz"] * w[2] ** 2)


@pytest.mark.parametrize(
    "name, bodies, platform, values",
    [
        ("prs3", [("m_s", ("c",)), ("m_r", ("c", "top"))], PLATE, {}),
        ("rrr3", [("m1", ("A", "C")), ("m2", ("C", "top"))], PLATE, {}),
        # the linear Delta's parallelogram is the paper's fictitious rod (no physical rods'
        # energy to compare with): its mass made negligible (1e-12 kg), the sliders and platform remain
        ("linear_delta", [("m_s", ("c",))], lambda d, w, v: d["m_pl"] / 2 * v @ v, {"m_r": 1e-12}),
    ],
)
def test_kinetic_energy_matches_finite_differences(gallery, name, bodies, platform, values):
    """1/2 t^T M t of the derived M equals the bodies' kinetic energy from central
    differences of their points along a random motion of the commanded coordinates (the
    followers' rates from differences of the completed poses): point masses, slender
    uniform rods m/6 (v1^2 + v1.v2 + v2^2), the platform's 1/2 m v^2 + 1/2 w^T I w."""
    ev = gallery[name]
    d = {**ev.robot.defaults, **values}
    x = _poses(ev, 6, seed=5)[:4]
    six = lambda f: np.pad(np.asarray(f), ((0, 0), (0, 6 - np.shape(f)[1])))  # noqa: E731  (rotation 0)
    full = six(ev.completion.poses(x))
    M = ev.matrices(x, "none", **values)["M"]
    rng = np.random.default_rng(7)
    for k in range(len(x)):
        dx = rng.standard_normal(3) * np.array([0.1 if c[0] != "r" else 1.0 for c in ev.pose_names])
        h = 1e-6  # followers move too: the full pose's rate
        dfull = (six(ev.completion.poses(x[k] + h * dx)) - six(ev.completion.poses(x[k] - h * dx)))[0] / (2 * h)
        T, twist = _energy(ev, full[k], dfull, bodies, platform, d)
        np.testing.assert_allclose(0.5 * twist @ M[k] @ twist, T, rtol=1e-6)


@pytest.mark.compiled
@pytest.mark.parametrize("name", ["rrr_rrr_prr", "tricept"])
def test_legs_that_differ_and_a_followed_orientation_numpy_equals_c(mechanisms, name):
    """The RRR-RRR-PRR (legs that differ, allowed twists that turn) and the Tricept (its
    orientation followed in C) on the C backend equal the NumPy stages to 1e-12, as above."""
    _check_numpy_equals_c(mechanisms[name], name)


@pytest.mark.compiled
@pytest.mark.parametrize("name", NAMES)
def test_numpy_equals_c(gallery, name):
    """The C backend (the fused pass with its allowed twists, followers and Newton legs in
    C) equals the NumPy stages to 1e-12 (the same arithmetic in another order: round-off,
    ~1e-15 at these poses, whose frequencies are well separated)."""
    ev = gallery[name]
    evc = _check_numpy_equals_c(ev, name)
    x = _poses(ev, 20, seed=3)
    mats = ev.matrices(x, "rigid")
    f6 = evc.modes(x, "rigid").freq_hz
    assert np.isfinite(f6).all() and f6.shape == (len(x), len(ev.pose_names))
    assert np.isfinite(mats["K_F"]).all()


@pytest.mark.parametrize("name", ("rus6", "upu3"))
@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.compiled)])
def test_the_branch_check_reads_the_levers_alone(gallery, name, backend):
    """Legs solved by Newton have a generated ``lever`` kernel: the jacobians kernel's levers
    (the sign each solution's branch is checked by) without its Jacobian rows, equal to them
    to round-off on either backend; the pose completion reads it. Closed-form legs have none."""
    ev = _on(gallery, name, backend)
    x = _poses(ev, 20, seed=5)
    q = ev.joint_angles(x)
    kp = ev.completion.closure_inputs(x, ev.resolver.resolve(len(x), {}, "none"))
    want = ev.kernels.jacobians(q, kp)["lever"]
    got = ev.kernels.lever(q, kp)["lever"]
    assert got.shape == want.shape == (len(x), len(ev.robot.legs))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())
    np.testing.assert_array_equal(ev.completion.levers(q, kp), got)
    assert "lever" not in eigentwist.load("heli4", backend=backend).kernels.OUTPUTS


def _check_numpy_equals_c(ev, name):
    """The C backend of the gallery robot ``name`` against its NumPy evaluator ``ev``: M, K_R,
    K_F, frequencies (1e-12) and eigentwists (1e-10) at 20 poses of its box; the C evaluator."""
    evc = eigentwist.load(str(GALLERY / f"{name}.py"), backend="c", threads=1, progress=None)
    x = _poses(ev, 20, seed=3)
    for model in ("rigid", "none"):
        a, b = ev.matrices(x, model), evc.matrices(x, model)
        for k in ("M", "K_R", "K_F"):
            np.testing.assert_allclose(b[k], a[k], rtol=0, atol=1e-12 * np.abs(a[k]).max())
        mn, mc = ev.modes(x, model), evc.modes(x, model)
        np.testing.assert_allclose(mc.freq_hz, mn.freq_hz, rtol=1e-12, atol=0)
        np.testing.assert_allclose(mc.eigentwists, mn.eigentwists, rtol=0, atol=1e-10)
    return evc


@pytest.mark.compiled
def test_c_backend_names_the_unreachable_leg():
    """A described robot's C pass names its own leg (not a shipped robot's) in one line."""
    ev = eigentwist.load(str(GALLERY / "rrr3.py"), backend="c", threads=1, progress=None)
    with pytest.raises(UnreachablePoseError, match="unreachable for leg 2: the leg cannot span") as err:
        ev.frequencies(np.array([[0.3, 0.0, 0.0]]), "none")
    assert "\n" not in str(err.value)


def test_a_reference_on_another_branch_is_refused(gallery):
    """The 3-UPU's first leg given a reference that does not close at x_ref and from which
    Newton closes on the other assembly branch (the strut's length negative): refused at
    load, naming the leg and the residual; a pose solved off the recorded branch is
    unreachable, naming the leg."""
    import dataclasses

    from eigentwist.runtime.errors import AssemblyError, UnreachablePoseError
    from eigentwist.runtime.evaluator import Evaluator

    ev = gallery["upu3"]
    legs = [leg.kinematics.leg for leg in ev.robot.legs]
    tilt, length = legs[0].reference[0], legs[0].reference[2]
    assert np.abs(ev.assembly()["residual"]).max() < 1e-12  # the shipped reference closes
    bad = dataclasses.replace(legs[0], reference=(tilt + 3.0, 0.0, length, 0.0, -tilt - 3.0))
    with pytest.raises(
        AssemblyError, match=r"leg 1's reference .* residual 0\.6\d+ \(m, rad\).*another assembly branch"
    ):
        Evaluator(dataclasses.replace(ev.robot, legs=(bad, *legs[1:])), ev.module, "numpy")
    flipped = Evaluator(ev.robot, ev.module, "numpy")
    flipped.assembly()["sign"][1] *= -1  # as if leg 2 had been assembled the other way
    with pytest.raises(UnreachablePoseError, match="unreachable for leg 2 on its assembly branch"):
        flipped.frequencies(ev.robot.x_ref)
    assert not flipped.valid(ev.robot.x_ref).any()


# -------------------------------------------------- mechanisms: legs that differ, point and passive platforms
#: home pose and frequencies (Hz, model "none") of shared/mechanisms-spec.md, computed there independently
SPEC = {
    "five_bar": ((0.0, 0.30), (36.209003312, 44.559195698)),
    "rrr_rrr_prr": ((0.0, 0.0, 0.0), (33.777014861, 54.983333791, 149.057795176)),
    "tricept": ((0.0, 0.0, 0.70), (160.688366317, 160.815893637, 410.315200634)),
    "five_bar_tube": ((0.0, 0.30), (37.129901478, 46.310150609)),
}


@pytest.fixture(scope="session")
def mechanisms():
    """The four mechanisms' evaluators (generated once into the session's cache, NumPy backend)."""
    return {name: eigentwist.load(str(GALLERY / f"{name}.py"), backend="numpy", progress=None) for name in SPEC}


@pytest.mark.parametrize("name", SPEC)
def test_mechanism_home_frequencies_are_the_specification(mechanisms, name):
    """Exactly as many finite modes as degrees of freedom (2, 3, 3), ascending, equal to the
    specification's to its printed digits; and none vanishes anywhere in the workspace box
    (a point platform's rotation is no mode)."""
    ev = mechanisms[name]
    home, expected = SPEC[name]
    names = {"five_bar": ("x", "y"), "five_bar_tube": ("x", "y"), "rrr_rrr_prr": ("x", "y", "rot_z")}
    assert ev.robot.x_ref == home and ev.pose_names == names.get(name, ("x", "y", "z"))
    f = ev.frequencies([home], "none")[0]
    np.testing.assert_allclose(f, expected, rtol=2e-11)
    f = ev.frequencies(_poses(ev, 12), "none")
    assert f.shape[1] == len(home) and (f > 20.0).all() and (np.diff(f, axis=1) >= 0).all()


def test_point_platform_has_no_rotation_mode(mechanisms):
    """The five-bar's pose space is the point's translations: two modes whatever the model,
    its allowed twists v_x, v_y exactly, which its legs' constraint wrenches annihilate."""
    ev = mechanisms["five_bar"]
    x = _poses(ev, 6)
    B = ev.allowed_twists(x)
    np.testing.assert_array_equal(B, np.broadcast_to(np.eye(6)[:, 3:5], (len(x), 6, 2)))
    A = _constraint_rows(ev, x)
    assert np.abs(A @ B).max() < 1e-12 * np.abs(A).max()
    assert ev.modes(x, "none").axes == ("x", "y")


def test_legs_differ_in_chain_actuator_and_stiffness(mechanisms):
    """The PRR leg's own axial stiffness k_p drives its share of K_R alone, the RRR legs' k_r
    theirs: K_R is linear in each (the sum of the two parts reproduces it), and the Tricept's
    passive central leg adds no stiffness (K_R's rank is the three actuators')."""
    ev = mechanisms["rrr_rrr_prr"]
    x = _poses(ev, 4)
    mats = ev.matrices(x, "none")
    K = mats["K_R"]
    # no c_rigid (rigid_compliance 0): the constraints are exact, K_F has no penalty spring and
    # without a structural compliance it is the actuators' K_R
    np.testing.assert_allclose(mats["K_F"], K, rtol=0, atol=1e-12 * np.abs(K).max())
    K_r = ev.matrices(x, "none", k_p=1e-9)["K_R"]
    K_p = ev.matrices(x, "none", k_r=1e-9)["K_R"]
    np.testing.assert_allclose(K_r + K_p, K, rtol=0, atol=1e-9 * np.abs(K).max())
    assert np.linalg.matrix_rank(K_r[0], tol=1e-6 * np.abs(K_r[0]).max()) == 2
    assert np.linalg.matrix_rank(K_p[0], tol=1e-6 * np.abs(K_p[0]).max()) == 1
    tri = mechanisms["tricept"]
    K = tri.matrices(_poses(tri, 3), "none")["K_R"]
    assert all(np.linalg.matrix_rank(k, tol=1e-9 * np.abs(k).max()) == 3 for k in K)


def test_tricept_orientation_follows_its_central_leg(mechanisms):
    """The followers put the platform's z axis along p (the central leg) and its y axis
    normal to base x (the U joint fixes the spin): R = Rx(alpha) Ry(beta) with
    beta = asin(e_x), alpha = atan2(-e_y, e_z), e = p/|p| (a few lines of NumPy)."""
    ev = mechanisms["tricept"]
    x = np.array([[0.0, 0.0, 0.70], [0.08, -0.05, 0.62], [-0.1, 0.1, 0.8]])
    R = rotation_matrix(np.asarray(ev.completion.poses(x))[:, 3:])
    for pose, Rk in zip(x, R):
        e = pose / np.linalg.norm(pose)
        b, a = np.arcsin(e[0]), np.arctan2(-e[1], e[2])
        Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
        np.testing.assert_allclose(Rk, Rx @ Ry, rtol=0, atol=1e-12)


def test_tube_sensitivity_moves_mass_and_inertia_with_length(mechanisms):
    """d f1/d l1 of the tube five-bar (the IK, m1 and I1 all move with l1) against central
    differences of the frequencies with Richardson extrapolation (1e-6), and the
    specification's -372.43817 Hz/m (1e-5)."""
    ev = mechanisms["five_bar_tube"]
    home = [[0.0, 0.30]]
    exact = ev.sensitivities(home, wrt=("l1",), model="none")[0, 0, 0]
    f = lambda l1: ev.frequencies(home, "none", l1=l1)[0, 0]  # noqa: E731
    d = lambda h: (f(0.18 + h) - f(0.18 - h)) / (2 * h)  # noqa: E731
    richardson = (4 * d(5e-5) - d(1e-4)) / 3
    assert abs(exact - richardson) <= 1e-6 * abs(richardson)
    assert abs(exact - (-372.43817)) <= 1e-5 * 372.43817


@pytest.mark.compiled
def test_point_platform_numpy_equals_c(mechanisms, monkeypatch):
    """The five-bar's C backend solves its 2 x 2 rigid model (the block of M and K_R at
    [v_x, v_y]) in the fused pass: the same matrices, frequencies and mode shapes as NumPy's
    reduction onto the point's translations; its parallel singularity refused the same way."""
    from eigentwist.runtime import evaluator as evaluator_module
    from eigentwist.runtime.errors import SingularPoseError

    ev = mechanisms["five_bar"]
    evc = eigentwist.load(str(GALLERY / "five_bar.py"), backend="c", threads=1, progress=None)
    x = _poses(ev, 10, seed=3)
    a, b = ev.matrices(x, "none"), evc.matrices(x, "none")
    for k in ("M", "K_R", "K_F"):
        np.testing.assert_allclose(b[k], a[k], rtol=1e-11, atol=1e-11 * np.abs(a[k]).max())
    assert evc.c_route.pass_rigid and not ev.c_route.pass_rigid
    chosen = []
    real = evaluator_module.choose_route
    monkeypatch.setattr(evaluator_module, "choose_route", lambda **kw: chosen.append(real(**kw)) or chosen[-1])
    mc, mn = evc.modes(x, "none"), ev.modes(x, "none")
    assert [r.solver for r in chosen] == ["pass", "matrices"]
    np.testing.assert_allclose(mc.freq_hz, mn.freq_hz, rtol=1e-12)
    np.testing.assert_allclose(mc.eigentwists, mn.eigentwists, rtol=0, atol=1e-11)
    d, l1, l2 = (ev.robot.defaults[k] for k in ("d", "l1", "l2"))
    y = np.sqrt(l1**2 - (l2 - d / 2) ** 2)
    with pytest.raises(SingularPoseError, match="parallel singular"):
        evc.frequencies([[0.0, y]], "none")
    assert evc.modes([[0.0, y], [0.0, y + 0.02]], "none", invalid="nan").valid.tolist() == [False, True]


def test_matrices_command_on_a_point_and_legs_that_differ(mechanisms, capsys):
    """`eigentwist matrices` on the five-bar: its rigid model on the point's two translations
    (the specification's home frequencies), the 6x6 flexible reference NaN (the point's
    rotations carry no inertia) instead of an error; on the RRR-RRR-PRR its shared k_r."""
    import json

    from eigentwist.cli.main import main

    assert (
        main(
            [
                "matrices",
                "--robot",
                str(GALLERY / "five_bar.py"),
                "--backend",
                "numpy",
                "--pose",
                "0",
                "0.3",
                "--model",
                "none",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(out["freq_hz"], SPEC["five_bar"][1], rtol=2e-11)
    assert out["frequencies_from"] == "M and K_R on the allowed twists, 2x2" and np.isnan(out["freq_flexible_hz"]).all()
    assert (
        main(
            [
                "matrices",
                "--robot",
                str(GALLERY / "rrr_rrr_prr.py"),
                "--backend",
                "numpy",
                "--pose",
                "0",
                "0",
                "0",
                "--model",
                "none",
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["k_a"] == 1.0e4 and out["k_a_unit"] == "N m/rad"


@pytest.mark.parametrize("name", ("tricept", "rrr_rrr_prr"))
def test_exact_condensation_of_legs_that_differ_is_the_rigid_model(mechanisms, name):
    """The legs kernel's elastic rows (the Tricept's UPS legs: one, padded to its passive
    central leg's three rigid constraint rows) condensed exactly give the rigid model's
    frequencies: the actuators as springs, every constraint rigid, padding inert."""
    from eigentwist.runtime import condense

    ev = mechanisms[name]
    x = _poses(ev, 4, seed=5)
    out = ev.run_kernel("legs", x, "none")
    f, _ = condense.condensed_modes(out["Je"], out["Cq"], out["K_ground"], ev.matrices(x, "none")["M"])
    n = len(ev.pose_names)
    assert np.isinf(f[:, n:]).all()
    np.testing.assert_allclose(f[:, :n], ev.frequencies(x, "none"), rtol=1e-9)


def test_robot_geometry_of_mechanisms(mechanisms):
    """The robot drawing's points: the Tricept's pose completed (its orientation followed),
    its UPS legs ending on the platform circle r = R_p around p and its central leg at p;
    the RRR-RRR-PRR's platform joints at r_p, the PRR leg starting at its slider on the
    rail; the stiffness argument only where the robot shares k_a."""
    from eigentwist.plots.robot import robot_geometry, stiffness_argument

    tri = mechanisms["tricept"]
    p = np.array([0.05, -0.03, 0.68])
    g = robot_geometry(tri, p)
    np.testing.assert_allclose(g.attachment[3], p, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(g.attachment[:3] - p, axis=1), 0.15, rtol=1e-12)
    R = rotation_matrix(np.asarray(tri.completion.poses(p[None]))[0, 3:])
    np.testing.assert_allclose(R[:, 2], p / np.linalg.norm(p), atol=1e-12)
    ev = mechanisms["rrr_rrr_prr"]
    g = robot_geometry(ev, [0.0, 0.0, 0.0])  # the specification's S ~ (-0.3354, 0.20) at home
    np.testing.assert_allclose(np.linalg.norm(g.attachment[:, :2], axis=1), 0.10, rtol=1e-12)
    assert abs(g.base[2, 1] - 0.20) < 1e-12 and abs(g.base[2, 0] - (-0.3354)) < 5e-5
    assert stiffness_argument(ev, 2000.0) == {} and stiffness_argument(tri, 2000.0) == {"k_a": 2000.0}


def test_sweep_of_legs_that_differ_sets_their_shared_stiffness(mechanisms):
    """A sweep's k_a column sets the RRR-RRR-PRR's shared k_r (its PRR leg keeps k_p): the
    worst-case lowest frequency over the poses equals the evaluator's at each k_r."""
    from eigentwist.runtime import sweep as sw
    from eigentwist.runtime.sweep.spec import stiffness_parameter

    path = str(GALLERY / "rrr_rrr_prr.py")
    ev = mechanisms["rrr_rrr_prr"]
    spec = sw.make_spec(path, model="none", random=16, seed=2, k_a=(1.0e4, 4.0e4), fixed={"k_p": 2.0e6})
    low = sw.run_sweep(spec).lowest
    f = ev.frequencies(np.asarray(spec.poses.take(np.arange(16))), "none")[:, 0]
    np.testing.assert_allclose(low["freq_hz"][0], f.min(), rtol=1e-12)
    f4 = ev.frequencies(np.asarray(spec.poses.take(np.arange(16))), "none", k_r=4.0e4)[:, 0]
    np.testing.assert_allclose(low["freq_hz"][1], f4.min(), rtol=1e-12)
    assert stiffness_parameter(ev) == "k_r" and stiffness_parameter(mechanisms["tricept"]) == "k_a"


def test_point_platform_parallel_singularity_is_said(mechanisms):
    """The five-bar's distal links in one line (C1, P, C2 collinear: by symmetry P on the
    y axis at y = sqrt(l1^2 - (l2 - d/2)^2), elbows out) leave the point free to move
    across that line: parallel singular, refused by ``frequencies``; a pose just beside it,
    and home, are not (the point's rotations, which no leg fixes, are no freedom)."""
    from eigentwist.runtime.errors import SingularPoseError

    ev = mechanisms["five_bar"]
    d, l1, l2 = (ev.robot.defaults[k] for k in ("d", "l1", "l2"))
    y = np.sqrt(l1**2 - (l2 - d / 2) ** 2)
    status = ev.pose_status([[0.0, y], [0.0, y + 0.02], [0.0, 0.30]])
    assert list(status["status"]) == ["parallel singular", "reachable", "reachable"]
    assert status["conditioning"][0] < 1e-6 < status["conditioning"][1]
    with pytest.raises(SingularPoseError, match="parallel singular"):
        ev.frequencies([[0.0, y]], "none")


@pytest.mark.parametrize("name", ("rus6", "upu3", "prs3", "rrr3"))
def test_sensitivities_equal_differences_of_the_frequencies(gallery, name):
    """Legs solved by Newton (implicit function theorem) and rigid models on allowed twists
    that turn with the pose: d f / d p equals central differences of frequencies() to 1e-6
    of f / p (poses off the symmetric home, where no two frequencies coincide)."""
    ev = gallery[name]
    _check_sensitivities(ev, [w for w in ("R_b", "R_p", "k_a") if w in ev.parameters])


@pytest.mark.parametrize(
    "name, wrt",
    [
        ("linear_delta", ("m_pl",)),  # closed form on fixed translations: the derived kernel
        ("five_bar", ("d", "l1", "l2")),  # a point's 2 x 2 on its translations: the derived kernel
        ("rrr_rrr_prr", ("b_x", "r_p", "k_r")),  # legs that differ, allowed twists that turn
        ("tricept", ("R_b", "R_p", "k_a")),  # a follower (the orientation) re-solved
    ],
)
def test_the_other_gallery_robots_sensitivities_equal_differences(gallery, mechanisms, name, wrt):
    """d f / d p of the rest of the gallery equals central differences of frequencies() to
    1e-6 of f / p, as above."""
    _check_sensitivities({**gallery, **mechanisms}[name], list(wrt))


@pytest.mark.parametrize("name", ("rus6", "prs3", "tricept"))
def test_weighted_mass_gradient_equals_differences(gallery, mechanisms, name):
    """<W, M>'s gradient (``sensitivity_route.weighted_mass``: what the optimiser's moving-mass
    constraint reads) equals central differences of ``matrices`` contracted with W to 1e-6:
    through legs solved by Newton (6-RUS), a lower-mobility platform's followers re-solved
    (3-PRS) and a followed orientation (Tricept); ``moving_mass`` by the kernel equals its own
    differences."""
    from eigentwist.design import moving_mass

    ev = {**gallery, **mechanisms}[name]
    rng = np.random.default_rng(12)
    W = rng.normal(size=(6, 6))
    W = W + W.T
    x = np.array(ev.robot.x_ref) + 0.02 * rng.standard_normal((2, len(ev.robot.x_ref)))
    x = x[ev.valid(x, "none")]
    wrt = [w for w in ("R_b", "R_p", "l_r", "l_c", "m_pl", "m_p") if w in ev.parameters]
    assert len(x) and len(wrt) >= 2
    value, grad = ev.sensitivity_route.weighted_mass(x, wrt, "none", {}, W)
    np.testing.assert_allclose(value, np.einsum("ij,nij->n", W, ev.matrices(x, "none")["M"]), rtol=1e-12)
    # the optimiser's moving mass at x_ref, exact against its own differences
    exact, by_differences = (moving_mass(ev, wrt, {}, "none", method) for method in ("exact", "differences"))
    assert exact[0] == pytest.approx(by_differences[0], rel=1e-12)
    np.testing.assert_allclose(exact[1], by_differences[1], rtol=1e-6, atol=1e-9 * abs(exact[0]))
    for j, w in enumerate(wrt):
        v = ev.defaults[w]
        h = 1e-5 * abs(v)
        hi, lo = (ev.matrices(x, "none", **{w: v + s * h})["M"] for s in (1, -1))
        fd = np.einsum("ij,nij->n", W, hi - lo) / (2 * h)
        assert np.abs(fd - grad[:, j]).max() <= 1e-6 * max(np.abs(fd).max(), abs(value).max() / abs(v)), (w, fd, grad)


def _check_sensitivities(ev, wrt):
    x = np.array(ev.robot.x_ref) + 0.02 * np.random.default_rng(7).standard_normal((2, len(ev.robot.x_ref)))
    x = x[ev.valid(x, "none")]
    assert len(x) and wrt
    modes, d = ev.modes_and_sensitivities(x, wrt, "none")
    f0 = ev.frequencies(x, "none")
    np.testing.assert_allclose(modes.freq_hz, f0, rtol=1e-9)
    for j, w in enumerate(wrt):
        v = ev.defaults[w]
        h = 1e-4 * abs(v)
        fd = (ev.frequencies(x, "none", **{w: v + h}) - ev.frequencies(x, "none", **{w: v - h})) / (2 * h)
        assert np.abs(fd - d[..., j]).max() <= 1e-6 * f0.max() / abs(v), (w, fd, d[..., j])


@pytest.mark.parametrize("name", ("rus6", "upu3"))
def test_joint_sensitivities_equal_differences_of_the_ik(gallery, name):
    """dq/dp by the implicit function theorem on the loop closure equals central differences
    of the Newton-solved joint coordinates (step 1e-6 relative) to 1e-7."""
    ev = gallery[name]
    x = np.array(ev.robot.x_ref) + 0.02 * np.random.default_rng(8).standard_normal((3, len(ev.robot.x_ref)))
    x = x[ev.valid(x, "none")]
    wrt = [w for w in ("R_b", "R_p", "l_r", "l_c") if w in ev.parameters]
    dq = ev.joint_sensitivities(x, wrt)
    assert dq.shape == ev.joint_angles(x).shape + (len(wrt),)
    for j, w in enumerate(wrt):
        v = ev.defaults[w]
        h = 1e-6 * abs(v)
        fd = (ev.joint_angles(x, **{w: v + h}) - ev.joint_angles(x, **{w: v - h})) / (2 * h)
        assert np.abs(fd - dq[..., j]).max() < 1e-7 * max(1.0, np.abs(fd).max())


def test_joint_sensitivities_need_a_loop_closure():
    from eigentwist.runtime.errors import InputError

    with pytest.raises(InputError, match="closed-form inverse kinematics"):
        eigentwist.load("delta", backend="numpy").joint_sensitivities([0.0, 0.0, -0.8], ["l1"])


@pytest.mark.compiled
@pytest.mark.parametrize("name", ("rus6", "prs3"))
def test_chunks_of_poses_on_threads_give_the_same_bits(gallery, name):
    """Past one chunk of poses, the C route completes whole chunks side by side on the
    threads (numeric IK: joint coordinates, rotation entries; followers): the joint
    coordinates, completed poses and frequencies equal one thread's bit for bit, and the
    first chunk's equal that chunk solved alone."""
    from eigentwist.runtime.completion import NEWTON_CHUNK as CHUNK

    one, two = (eigentwist.load(str(GALLERY / f"{name}.py"), backend="c", threads=t, progress=None) for t in (1, 2))
    x = _poses(gallery[name], int(1.6 * (CHUNK + 300)), seed=9)[: CHUNK + 300]
    assert len(x) == CHUNK + 300
    f1 = one.frequencies(x, "none")
    assert np.isfinite(f1).all()
    assert np.array_equal(two.frequencies(x, "none"), f1)
    assert np.array_equal(two.completed_poses(x), one.completed_poses(x))
    assert np.array_equal(two.frequencies(x[:CHUNK], "none"), f1[:CHUNK])
    if name == "rus6":
        assert np.array_equal(two.joint_angles(x), one.joint_angles(x))


@pytest.mark.compiled
def test_followers_solved_in_c_equal_numpy(gallery, monkeypatch):
    """The 3-PRS's followers (x, y, rot_z) iterated by the C driver on the compiled followers
    kernel equal the NumPy iterations: at the home pose (zero rotation: the series of
    Rodrigues and of the left Jacobian), near it and over the workspace, on one thread and
    on two (ranges of whole blocks: the same bits)."""
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD

    ev = gallery["prs3"]
    evc = eigentwist.load(str(GALLERY / "prs3.py"), backend="c", threads=1, progress=None)
    assert "followers" in evc._kernels.OUTPUTS
    x = _poses(ev, 2 * MIN_BLOCKS_PER_THREAD * 64 + 40, seed=4)
    x[:3] = ev.robot.x_ref
    x[1, 1:] += 1e-7  # rotations near zero
    x[2, 1:] += 3e-6
    want = ev.completed_poses(x)
    got = evc.completed_poses(x)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    two = eigentwist.load(str(GALLERY / "prs3.py"), backend="c", threads=2, progress=None)
    assert np.array_equal(two.completed_poses(x), got)
    evc.c_newton = False  # the NumPy iterations around the same evaluator: the same poses
    np.testing.assert_allclose(evc.completed_poses(x[:50]), want[:50], rtol=0, atol=1e-12)
    evc.c_newton = True  # a follower that does not converge: unreachable, named, in C too
    from eigentwist.runtime import platform

    monkeypatch.setattr(platform, "MAX_STEPS", 1)
    with pytest.raises(UnreachablePoseError) as err:
        evc.frequencies(np.array([[0.60, 0.1, -0.1]]), "rigid")
    assert "rot_x = 0.1" in str(err.value) and "did not converge" in str(err.value)


@pytest.mark.compiled
def test_the_followers_first_stage_over_the_batch_gives_each_chunks_bits(monkeypatch):
    """3-PRS on the C backend, two threads: the followers' first stage runs once over the
    batch (one C call, its blocks on the threads) and only the chunks with a pose that does not
    converge there are completed the long way; every completed pose equals, bit for bit, the
    long way run chunk by chunk (:func:`~eigentwist.runtime.platform.full_poses` with the C
    iterations). With one Newton step an attempt, small tilts converge and three tilts of
    0.14 rad do not (NaN in their rows alone)."""
    from eigentwist.runtime import completion, platform
    from eigentwist.runtime.completion import chunks, take
    from eigentwist.runtime.platform import full_poses

    ev = eigentwist.load(str(GALLERY / "prs3.py"), backend="c", threads=2, progress=None)
    comp = ev.completion
    monkeypatch.setattr(completion, "NEWTON_CHUNK", 128)
    monkeypatch.setattr(platform, "MAX_STEPS", 1)
    rng = np.random.default_rng(3)
    x = np.column_stack([0.6 + 0.05 * rng.random(600), 0.01 * (rng.random((600, 2)) - 0.5)])
    x[[150, 151, 400], 1] = 0.14
    followers = [FULL.index(c) for c in comp.space.followers]
    calls = []
    follow = ev.kernels.follow

    def counted(q, *a, **kw):
        calls.append(len(q))
        return follow(q, *a, **kw)

    monkeypatch.setattr(ev.kernels, "follow", counted)
    got = np.asarray(comp.poses(x))
    assert calls[0] == 600 and calls.count(128) == 2  # the batch, then the two chunks with a failure
    p = comp.resolver.resolve(len(x), {}, "rigid")

    def its(q, pp, iterations, tol):
        return follow(q, pp, followers, iterations, tol, threads=1)

    want = np.concatenate(
        [full_poses(comp.space, x[sl], comp.module.followers, take(p, sl), None, its) for sl in chunks(600, 128)]
    )
    assert got.tobytes() == want.tobytes()
    assert np.isnan(got[[150, 151, 400]]).any(axis=1).all() and np.isfinite(np.delete(got, [150, 151, 400], 0)).all()


@pytest.mark.compiled
@pytest.mark.parametrize("name", ["prs3", "rrr3"])
def test_allowed_twists_chunk_by_chunk_change_no_bit(monkeypatch, name):
    """A lower-mobility or planar robot's rigid model on the C backend: the pass, the allowed
    twists and the reductions run chunk by chunk (``CHUNK`` poses, each chunk's outputs in
    one of a few reused buffers, whole chunks on the threads). Chunks of 128 poses on two
    threads (a last partial chunk, buffers reused) give the frequencies of one chunk on one
    thread bit for bit; the buffer sets are kept for the next call (one a thread at most, a
    new queue for another chunk size); an unreachable pose in a later chunk raises, naming the
    first one."""
    from eigentwist.runtime import mode_solver

    one = eigentwist.load(str(GALLERY / f"{name}.py"), backend="c", threads=1, progress=None)
    two = eigentwist.load(str(GALLERY / f"{name}.py"), backend="c", threads=2, progress=None)
    x = _poses(one, 900, seed=5)[:600]
    assert len(x) == 600
    monkeypatch.setattr(mode_solver, "CHUNK", 1 << 20)
    whole = one.frequencies(x, "rigid")
    kept = one.solver.chunk_buffers()
    assert kept.qsize() == 1 and one.solver.chunk_buffers() is kept  # one set, kept for the next call
    monkeypatch.setattr(mode_solver, "CHUNK", 128)
    assert one.solver.chunk_buffers() is not kept  # sets of another size
    assert two.frequencies(x, "rigid").tobytes() == whole.tobytes()
    assert 1 <= two.solver.chunk_buffers().qsize() <= 2  # at most one set a thread
    assert len(next(iter(two.solver.chunk_buffers().get().values()))) == 128
    assert one.frequencies(x, "rigid").tobytes() == whole.tobytes()
    far = x.copy()
    column, first, second = (1, 2.5, 2.7) if name == "prs3" else (0, 5.0, 7.0)  # beyond the legs' reach
    far[450, column], far[500, column] = first, second
    with pytest.raises(UnreachablePoseError) as err:
        two.frequencies(far, "rigid")
    assert f"{first:.1f}" in str(err.value) and f"{second:.1f}" not in str(err.value)
