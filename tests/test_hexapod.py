"""The Gough-Stewart hexapod from joint lists: physics identities at 6-DoF poses.

The model is the shipped generated one, ``eigentwist.load("hexapod")`` (NumPy and C);
every reference here is computed independently in a few lines of NumPy from the leg
vectors.
"""

from __future__ import annotations


import numpy as np
import pytest
from scipy.linalg import eigh

import eigentwist
from eigentwist.robots import hexapod
from eigentwist.runtime.errors import InputError
from eigentwist.runtime.poses import exp_twist, rotation_matrix

HOME = np.array([0.0, 0.0, 0.80, 0.0, 0.0, 0.0])
TILTED = np.array([0.03, -0.02, 0.82, 0.08, -0.05, 0.12])


@pytest.fixture(scope="module")
def robot():
    return hexapod.describe()


@pytest.fixture(scope="module", params=["numpy", "c"])
def ev(request):
    return eigentwist.load("hexapod", backend=request.param)


@pytest.fixture(scope="module")
def evaluate(ev):
    """``evaluate(pose, on, **params)``: the evaluator's matrices, leg lengths and
    actuation rows at one pose, with the effects ``on`` switched on."""

    def run(pose, on=(), **params):
        model = ",".join(on) or "none"
        out = dict(ev.matrices(pose, model, **params))
        out["q_a"] = ev.joint_angles(pose, **params)[..., 0]
        out["J_a"] = ev.jacobians(pose, **params)["J_rows"][:, :, 0, :]
        return out

    return run


def random_poses(n, seed) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = np.array([-0.08, -0.08, 0.72, -0.15, -0.15, -0.3])
    return lo + (-2 * lo * np.array([1, 1, 0, 1, 1, 1]) + np.array([0, 0, 0.16, 0, 0, 0])) * rng.random((n, 6))


def joints(robot, pose):
    """Base and platform joint points (6, 3) in m, base frame, at ``pose``."""
    p = robot.defaults
    ang = lambda deg: np.radians(np.asarray(deg, dtype=float))  # noqa: E731
    circle = lambda r, deg: r * np.stack([np.cos(ang(deg)), np.sin(ang(deg)), 0 * ang(deg)], axis=1)  # noqa: E731
    b = circle(p["R_b"], hexapod.BASE_ANGLES)
    a = circle(p["R_p"], hexapod.PLATFORM_ANGLES)
    return b, pose[:3] + a @ rotation_matrix(pose[3:]).T


def lengths(robot, pose) -> np.ndarray:
    b, top = joints(robot, pose)
    return np.linalg.norm(top - b, axis=1)


def kinetic_energy_fd(robot, pose, twist, eps=1e-6) -> float:
    """Kinetic energy of platform, cylinders and pistons from central differences of
    their positions along the exponential map (struts: no spin about their axis)."""
    p = robot.defaults
    states = []
    for e in (-eps, eps):
        q = exp_twist(pose, twist, e)
        b, top = joints(robot, q)
        s = (top - b) / np.linalg.norm(top - b, axis=1)[:, None]
        R = rotation_matrix(q[3:])
        states.append((b + p["d_cyl"] * s, top - p["d_pis"] * s, s, q[:3] + R @ [0, 0, p["c_pl"]]))
    (c0, p0, s0, g0), (c1, p1, s1, g1) = states
    d = lambda u, w: (w - u) / (2 * eps)  # noqa: E731
    s_mid = (s0 + s1) / 2
    w_strut = np.cross(s_mid, d(s0, s1))
    R = rotation_matrix(pose[3:])
    omega = twist[:3]
    I_pl = R @ np.diag([p["I_pl_xx"], p["I_pl_yy"], p["I_pl_zz"]]) @ R.T
    return 0.5 * (
        p["m_cyl"] * np.sum(d(c0, c1) ** 2)
        + p["m_pis"] * np.sum(d(p0, p1) ** 2)
        + (p["I_cyl"] + p["I_pis"]) * np.sum(w_strut**2)
        + p["m_pl"] * np.sum(d(g0, g1) ** 2)
        + omega @ I_pl @ omega
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_kinetic_energy_equals_half_tMt(robot, evaluate, seed):
    rng = np.random.default_rng(seed)
    pose = random_poses(1, seed)[0]
    M = evaluate(pose)["M"][0]
    for _ in range(3):
        t = rng.normal(size=6) * np.array([0.5, 0.5, 0.5, 0.2, 0.2, 0.2])
        assert 0.5 * t @ M @ t == pytest.approx(kinetic_energy_fd(robot, pose, t), rel=1e-6)


@pytest.mark.parametrize("seed", [4, 5])
def test_stiffness_equals_JT_Kq_J_from_leg_lengths(robot, evaluate, seed):
    eps = 1e-6
    for pose in random_poses(3, seed):
        J = np.stack(
            [
                (lengths(robot, exp_twist(pose, e, eps)) - lengths(robot, exp_twist(pose, e, -eps))) / (2 * eps)
                for e in np.eye(6)
            ],
            axis=1,
        )
        K_fd = J.T @ (robot.defaults["k_a"] * J)
        out = evaluate(pose)
        K = out["K_R"][0]
        assert np.abs(K - K_fd).max() <= 1e-6 * np.abs(K).max()
        np.testing.assert_allclose(out["q_a"][0], lengths(robot, pose), rtol=1e-12)
        np.testing.assert_allclose(out["J_a"][0], J, atol=1e-6)


def test_joint_series_effects_soften_the_struts(robot, evaluate):
    p = robot.defaults
    k = 1 / (1 / (p["eta_a"] * p["k_a"]) + 1 / p["k_s"] + 2 / p["k_j"])
    on = ("actuator_loss", "strut_compliance", "joint_compliance")
    K_on = evaluate(TILTED, on)["K_R"][0]
    K_off = evaluate(TILTED)["K_R"][0]
    np.testing.assert_allclose(K_on, K_off * k / p["k_a"], rtol=1e-10, atol=1e-9 * np.abs(K_off).max())


def _frequencies(out) -> np.ndarray:
    return np.sqrt(eigh(out["K_R"][0], out["M"][0], eigvals_only=True)) / (2 * np.pi)


def test_home_symmetry_gives_equal_pairs(robot, evaluate):
    out = evaluate(HOME)
    f = _frequencies(out)
    pairs = [(i, i + 1) for i in range(5) if abs(f[i + 1] - f[i]) < 1e-9 * f[-1]]
    assert len(pairs) == 2, f
    phi = 2 * np.pi / 3
    Rz = np.array([[np.cos(phi), -np.sin(phi), 0], [np.sin(phi), np.cos(phi), 0], [0, 0, 1]])
    T = np.kron(np.eye(2), Rz)
    for name in ("M", "K_R"):
        A = out[name][0]
        np.testing.assert_allclose(T @ A @ T.T, A, atol=1e-9 * np.abs(A).max())


def test_mirror_symmetry_about_xz(robot, evaluate):
    pose = np.array([0.04, 0.0, 0.78, 0.0, 0.07, 0.0])  # a pose in the mirror plane
    D = np.diag([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])  # y -> -y on [omega (axial); v]
    out = evaluate(pose)
    for name in ("M", "K_R"):
        A = out[name][0]
        np.testing.assert_allclose(D @ A @ D, A, atol=1e-9 * np.abs(A).max())
    np.testing.assert_allclose(
        _frequencies(evaluate(TILTED * [1, -1, 1, -1, 1, -1])), _frequencies(evaluate(TILTED)), rtol=1e-9
    )


@pytest.mark.parametrize("pose", [HOME, TILTED])
def test_massless_struts_match_platform_and_line_coordinates(robot, evaluate, pose):
    tiny = 1e-15  # masses must be positive: massless up to 1e-15 kg, kg m^2
    f = _frequencies(evaluate(pose, m_cyl=tiny, m_pis=tiny, I_cyl=tiny, I_pis=tiny))
    p = robot.defaults
    b, top = joints(robot, pose)
    s = (top - b) / np.linalg.norm(top - b, axis=1)[:, None]
    j = np.hstack([np.cross(top - pose[:3], s), s])  # line coordinates at the platform origin
    K = p["k_a"] * j.T @ j
    R = rotation_matrix(pose[3:])
    c = R @ [0, 0, p["c_pl"]]
    C = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    I_o = R @ np.diag([p["I_pl_xx"], p["I_pl_yy"], p["I_pl_zz"]]) @ R.T - p["m_pl"] * C @ C
    M = np.block([[I_o, p["m_pl"] * C], [-p["m_pl"] * C, p["m_pl"] * np.eye(3)]])
    np.testing.assert_allclose(f, np.sqrt(eigh(K, M, eigvals_only=True)) / (2 * np.pi), rtol=1e-9)


def test_payload_at_the_origin_lowers_all_but_the_twist_about_z(robot, evaluate):
    f0 = _frequencies(evaluate(HOME))
    f1 = _frequencies(evaluate(HOME, ("payload_mass",)))
    assert (f1 <= f0 * (1 + 1e-12)).all() and (f1 < f0 * (1 - 1e-6)).sum() == 5  # a point mass: no inertia about z


@pytest.mark.derives
def test_generation_renders_every_backend(rendered):
    """Derivation, CSE and rendering of every backend of the hexapod (its time, goal < 60 s,
    is measured in benchmarks/hexapod.py: speed is never asserted in tests);
    ``rendered`` is conftest's ``render_all()``, whose hexapod files are ``render_robot("hexapod")``'s."""
    files = {k: v for k, v in rendered.items() if k.startswith("hexapod_")}
    assert set(files) == {"hexapod_numpy.py", "hexapod_c.c", "hexapod_c.h"}


def test_units_follow_the_joint_kind(robot):
    assert robot.parameter("k_a").unit == "N/m"
    assert robot.parameter("k_s").unit == "N/m"


def test_frequencies_are_the_rigid_6x6_eigenproblem(ev, evaluate):
    """The rigid model of a 6-DoF robot is the full 6x6 M and K_R."""
    on = ("actuator_loss", "payload_mass")
    m = ev.modes(np.stack([HOME, TILTED]), "actuator_loss,payload_mass", k_a=1.0e7)
    assert m.stiffness_model == "rigid" and m.axes == ("rx", "ry", "rz", "x", "y", "z") and m.freq_hz.shape == (2, 6)
    np.testing.assert_allclose(m.freq_hz[1], _frequencies(evaluate(TILTED, on, k_a=1.0e7)), rtol=1e-10)
    assert ev.frequencies(HOME, "rigid").shape == (1, 6)


@pytest.mark.compiled  # compiles the hexapod's C (make test, not make test-fast)
def test_c_equals_numpy():
    poses = random_poses(200, 9)
    a, b = (eigentwist.load("hexapod", backend=k) for k in ("numpy", "c"))
    for model in ("rigid", "actuator_loss,strut_compliance,joint_compliance,payload_mass"):
        ma, mb = a.matrices(poses, model), b.matrices(poses, model)
        for k in ("M", "K_R", "K_F"):
            scale = np.abs(ma[k]).max(axis=(1, 2))[:, None, None]
            assert (np.abs(ma[k] - mb[k]) <= 1e-12 * scale).all(), k
        np.testing.assert_allclose(b.frequencies(poses, model), a.frequencies(poses, model), rtol=1e-10)


def test_pose_width_names_the_coordinates(ev):
    with pytest.raises(InputError, match=r"\(N, 6\) poses of hexapod, columns x, y, z, rot_x, rot_y, rot_z"):
        ev.frequencies([0.0, 0.0, 0.8])
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        eigentwist.load("heli4", backend="numpy").frequencies(HOME)


def test_a_zero_length_leg_is_unreachable(ev):
    """Platform joint 1 placed on base joint 1: leg 1 has no direction (length 0, or a
    round-off length whose leg twists are degenerate: the lever w_a . t_a vanishes)."""
    from eigentwist.runtime.errors import SingularPoseError, UnreachablePoseError

    ang = np.radians([-10.0, -50.0])
    b1, a1 = 0.5 * np.array([np.cos(ang[0]), np.sin(ang[0])]), 0.3 * np.array([np.cos(ang[1]), np.sin(ang[1])])
    bad = np.array([*(b1 - a1), 0.0, 0.0, 0.0, 0.0])
    assert ev.valid(np.stack([HOME, bad])).tolist() == [True, False]
    with pytest.raises((UnreachablePoseError, SingularPoseError), match="leg 1"):
        ev.frequencies(bad)


def _line_rows(robot, pose) -> np.ndarray:
    """(6, 6) unit wrenches along the struts at the platform origin: [r x s; s]."""
    b, top = joints(robot, pose)
    s = (top - b) / np.linalg.norm(top - b, axis=1)[:, None]
    return np.hstack([np.cross(top - pose[:3], s), s])


def test_gravity_preload_is_the_derivative_of_the_strut_wrenches(robot, ev):
    """K_G = sym(sum_i f_i d(j_i^T)/d twist) with the strut forces f balancing the weight
    (J^T f = W), every derivative by central differences along the exponential map."""
    pose, eps, g = TILTED, 1e-6, 9.81
    p = robot.defaults
    R = rotation_matrix(pose[3:])
    c = R @ [0, 0, p["c_pl"]]
    weight = p["m_pl"] * np.array([0, 0, -g])
    W = np.concatenate([np.cross(c, weight), weight])
    f = np.linalg.solve(_line_rows(robot, pose).T, W)
    KG = np.stack(
        [
            f @ (_line_rows(robot, exp_twist(pose, e, eps)) - _line_rows(robot, exp_twist(pose, e, -eps))) / (2 * eps)
            for e in np.eye(6)
        ],
        axis=1,
    )
    KG = 0.5 * (KG + KG.T)
    _, K0 = ev.stiffness(pose, "none")
    _, K1 = ev.stiffness(pose, "gravity_preload", g=g)
    assert np.abs((K1 - K0)[0] - KG).max() <= 1e-6 * np.abs(KG).max()
    assert np.abs(KG).max() > 1e-6 * np.abs(K0).max()  # the term is not negligible here
