"""Damped modes (servo damping, a torque lag, a structural loss factor) against independent
computations written here, their limits and thresholds, and damping in the measurements."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime import InputError, UnstablePoseError
from eigentwist.runtime.damped import ELIMINATE, UNSTABLE_ZETA, damped_modes

X_REF = np.array([0.0, 0.0, -0.625])
POSES = np.array([X_REF, [0.05, -0.03, -0.6]])
ETA = 0.82  # the Heli4's eta_a (App. B)


_EVALUATORS: dict = {}


@pytest.fixture(params=["numpy", "c"])
def backend(request):
    """The Heli4 evaluator of each damped solver: the NumPy backend's (:mod:`.damped` in
    NumPy) and the C backend's (the compiled driver, :mod:`.c_damped`)."""
    if request.param == "c":
        from eigentwist.runtime.ccompile import CompilerNotFoundError, find_compiler

        from .conftest import skip_tier

        try:
            find_compiler()
        except CompilerNotFoundError as exc:
            skip_tier("compiled", str(exc))
    if request.param not in _EVALUATORS:
        _EVALUATORS[request.param] = __import__("eigentwist").load("heli4", backend=request.param)
    return _EVALUATORS[request.param]


def _upper(s):
    """The poles of positive frequency, ascending, as frequencies in Hz."""
    return np.sort(s[s.imag > 0].imag) / (2 * np.pi)


def test_against_a_state_space_model_written_here(backend):
    """Each leg: structure (stiffness K_s = C_s^-1 on its elastic joints) in series with a
    PD servo of lagged torque (t tau' + tau = k_d th + c_d th'), its internal angle th a
    massless coordinate; state [x, v, th] (16) solved by numpy.linalg.eigvals."""
    p = dict(k_a=125.0, c_a=3.0, t_d=0.002)
    legs = backend.run_kernel("legs", POSES, "paper", **p)
    M = backend.matrices(POSES, "paper", **p)["M"]
    modes = backend.modes(POSES, "damped,servo_delay", **p)
    kd, cd, t = ETA * 125.0, ETA * 3.0, 0.002
    for k in range(len(POSES)):
        A = np.zeros((16, 16))
        A[:6, 6:12] = np.eye(6)
        Kxx, Kxt = np.zeros((6, 6)), np.zeros((6, 4))
        for i in range(4):
            Je, Cs = legs["Je"][k, i], legs["Cq"][k, i].copy()
            Cs[0, 0] -= 1 / kd  # the actuator's own compliance out: the structure
            Ks = np.linalg.inv(Cs)
            e0 = np.eye(len(Cs))[0]
            Kxx += Je.T @ Ks @ Je
            Kxt[:, i] = -Je.T @ Ks @ e0
            a, hs = e0 @ Ks @ Je, e0 @ Ks @ e0  # tau = a x - hs th
            den = cd + t * hs
            A[12 + i, :6], A[12 + i, 6:12], A[12 + i, 12 + i] = a / den, t * a / den, -(hs + kd) / den
        A[6:12, :6] = -np.linalg.solve(M[k], Kxx)
        A[6:12, 12:] = -np.linalg.solve(M[k], Kxt)
        np.testing.assert_allclose(np.sort(modes.damped_hz[k]), _upper(np.linalg.eigvals(A)), rtol=1e-9)


def test_rigid_model_is_a_damping_matrix(backend):
    """The rigid model (K_R on the translations, Eq. 14): M x'' + C x' + K x = 0 with
    C = sum_i eta c_a J_a,i^T J_a,i, by the companion matrix."""
    rows = backend.jacobians(X_REF)["J_rows"][0, :, 0, 3:]  # actuated rows, translational part
    M3 = backend.matrices(X_REF, "rigid")["M"][0, 3:, 3:]
    K = ETA * 500.0 * rows.T @ rows
    C = ETA * 3.0 * rows.T @ rows
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-np.linalg.solve(M3, K), -np.linalg.solve(M3, C)]])
    modes = backend.modes(X_REF, "rigid,servo_damping", k_a=500.0)
    np.testing.assert_allclose(np.sort(modes.damped_hz[0]), _upper(np.linalg.eigvals(A)), rtol=1e-9)


@pytest.mark.parametrize("model", ["damped", "rigid,servo_damping", "damped,servo_delay"])
def test_undamped_limit(backend, model):
    """c_a = 0 and t_d = 0: every pole is +/- i omega of today's frequencies (1e-12)."""
    undamped = backend.frequencies(
        POSES, model.replace(",servo_delay", "").replace("damped", "paper").replace(",servo_damping", ""), k_a=125.0
    )
    modes = backend.modes(POSES, model, k_a=125.0, c_a=0.0, t_d=0.0, complex_shapes=True)
    np.testing.assert_allclose(modes.freq_hz, undamped, rtol=1e-12)
    np.testing.assert_allclose(modes.damped_hz, undamped, rtol=1e-12)
    np.testing.assert_allclose(modes.natural_hz, undamped, rtol=1e-12)
    np.testing.assert_allclose(modes.damping_ratio, 0.0, atol=1e-12)
    real = modes.complex_eigentwists  # undamped shapes are real: today's eigentwists
    np.testing.assert_allclose(real.imag, 0.0, atol=1e-9)
    poles = backend.modes(POSES, model, k_a=125.0, c_a=0.0, t_d=0.0, vectors=False)  # the solver's own route
    np.testing.assert_allclose(poles.damped_hz, undamped, rtol=1e-12)
    np.testing.assert_allclose(poles.damping_ratio, 0.0, atol=1e-12)


def test_paper_numbers_do_not_move(backend):
    """The 'damped' preset (c_a = 3, the paper's servos) keeps the undamped frequencies of
    'paper' (Eq. 65) in freq_hz; the damping lowers the damped ones, most at low k_a."""
    paper = backend.modes(X_REF, "paper", k_a=2000.0)
    damped = backend.modes(X_REF, "damped", k_a=2000.0)
    np.testing.assert_array_equal(damped.freq_hz, paper.freq_hz)
    np.testing.assert_allclose(paper.freq_hz[0, :2], [20.723, 23.932], atol=5e-4)  # facts file
    assert paper.damping is None and np.all(paper.damping_ratio == 0)
    low = backend.modes(X_REF, "damped", k_a=125.0)
    drop = 1 - low.damped_hz[0, :2] / low.freq_hz[0, :2]
    assert np.all((drop > 0.09) & (drop < 0.13))  # 9-12 % at k_a = 125
    assert np.all((low.damping_ratio[0, :2] > 0.4) & (low.damping_ratio[0, :2] < 0.5))


def test_structural_loss_against_a_complex_stiffness(ev):
    """A loss factor alone (elastic servos): det(K_c - omega^2 M) = 0 with the legs' passive
    compliance C_s / (1 + i eta_s), by scipy's generalized eigen-solver."""
    from scipy.linalg import eigvals

    eta_s = 0.05
    legs = ev.run_kernel("legs", X_REF, "paper", k_a=2000.0)
    M = ev.matrices(X_REF, "paper", k_a=2000.0)["M"][0]
    Kc = np.zeros((6, 6), dtype=complex)
    for i in range(4):
        Je, Cq = legs["Je"][0, i], legs["Cq"][0, i].astype(complex)
        act = 1 / (ETA * 2000.0)
        Cq[0, 0] -= act
        Cq = Cq / (1 + 1j * eta_s)
        Cq[0, 0] += act
        Kc += Je.T @ np.linalg.inv(Cq) @ Je
    s = 1j * np.sqrt(eigvals(Kc, M))  # s^2 = -lambda, the root of positive frequency
    modes = ev.modes(X_REF, "paper,structural_loss", k_a=2000.0, eta_s=eta_s)
    order = np.argsort(s.imag)
    np.testing.assert_allclose(modes.damping.poles[0], s[order], rtol=1e-9)
    assert modes.damping_ratio[0, 5] == pytest.approx(eta_s / 2, rel=0.02)  # a purely structural mode


def _one_mode(beta_factor=None, zeta=None, solver="numpy"):
    """One mode (M = 1, omega = 2 pi 10 Hz) and one actuator leg (w = 1, k_d = 1000)."""
    om, kd, c = 2 * np.pi * 10.0, 1000.0, 1.0
    if zeta is not None:  # an eliminated leg, c chosen for this zeta
        c, h = 2 * zeta * om * kd**2, kd
    else:  # beta = c (k_d - h) at beta_factor x the threshold
        h = kd - beta_factor * ELIMINATE * kd**2 / (c * om)
    d = damped_modes(
        np.ones((1, 1, 1)), np.full((1, 1, 1), om**2), np.ones((1, 1, 1)), np.array([[h]]), kd, c, 0.0, solver=solver
    )
    return d, om, kd, c


@pytest.mark.parametrize("backend", ["numpy", "c"])  # the solver (a string here, not the fixture)
@pytest.mark.parametrize("factor", [0.5, 2.0])
def test_elimination_threshold(factor, backend):
    """A leg's internal pole just beyond (0.5) or inside (2) the ELIMINATE bound: the same
    pole as s^2 + (c w^2/k_d^2) s + omega^2 = 0 (the leg eliminated), to 1e-6."""
    d, om, kd, c = _one_mode(beta_factor=factor, solver=backend)
    exact = np.roots([1.0, c / kd**2, om**2])
    assert d.poles[0, 0] == pytest.approx(exact[exact.imag > 0][0], rel=1e-6)


@pytest.mark.parametrize("backend", ["numpy", "c"])  # the solver
@pytest.mark.parametrize("zeta, stable", [(-2 * UNSTABLE_ZETA, False), (-0.5 * UNSTABLE_ZETA, True)])
def test_unstable_threshold(zeta, stable, backend):
    d, *_ = _one_mode(zeta=zeta, solver=backend)
    assert d.damping_ratio[0, 0] == pytest.approx(zeta, rel=1e-3)
    assert bool(d.stable[0]) is stable


def test_torque_lag_destabilises_above_c_over_t(backend):
    """c_a = 3 with a 1.3 ms lag: negative damping above k_a ~ c_a / t_d = 2300 N m/rad, where
    the paper measured decaying oscillations."""
    ka = np.array([2200.0, 2400.0])
    modes = backend.modes(np.tile(X_REF, (2, 1)), "damped,servo_delay", k_a=ka, t_d=1.3e-3, vectors=False)
    assert modes.stable.tolist() == [True, False]
    assert modes.damping_ratio[1, 0] < 0 < modes.damping_ratio[0, 0]
    with pytest.raises(UnstablePoseError, match="damping ratio"):
        backend.modes(X_REF, "damped,servo_delay", k_a=4000.0, t_d=1.3e-3, unstable="raise")


def test_damping_parameters_closed_at_zero(ev):
    ev.modes(X_REF, "damped", c_a=0.0)
    with pytest.raises(InputError, match=r"'c_a' = -1e-09 N m s/rad: expected a finite value >= 0"):
        ev.modes(X_REF, "damped", c_a=-1e-9)
    with pytest.raises(InputError, match="damping effect"):
        ev.modes(X_REF, "damped", joints=ev.joint_angles(X_REF))


# ----------------------------------------------------------------- measurements
def test_kind_and_damping_ratio_columns(ev):
    from eigentwist.diagnose.measurements import MeasurementError, paper_measurements, parse_csv

    assert paper_measurements(ev).damped.all()  # camera frames of step responses (Sec. 4)
    text = "k_a,mode,freq_hz,kind,damping_ratio\n125,x,5.4,damped,0.02\n250,x,8.1,,0.03\n"
    meas = parse_csv(text, "m.csv", ev)
    assert meas.kind == ("damped", "undamped")
    # default sigma: the larger of 20 % of zeta and 0.005 (0.004 -> 0.005; 0.006)
    np.testing.assert_allclose(meas.sigma_damping_ratio, [0.005, 0.006])
    assert "kind" in meas.to_csv() and parse_csv(meas.to_csv(), "m.csv", ev).kind == meas.kind
    with pytest.raises(MeasurementError, match=r"line 2, column 'kind': kind 'decay'"):
        parse_csv("k_a,mode,freq_hz,kind\n125,x,5.4,decay\n", "m.csv", ev)


def test_compare_like_with_like(ev):
    """A damped row is compared with omega_d, an undamped one with omega_n = |s|."""
    from eigentwist.diagnose import compare
    from eigentwist.diagnose.measurements import Measurements

    meas = Measurements.from_arrays(
        125.0,
        ["x", "x"],
        [5.3, 5.9],
        poses=[X_REF, X_REF],
        ev=ev,
        kind=["damped", "undamped"],
        params={"E_rod": [170e9, 169e9]},
    )
    modes = ev.modes(np.tile(X_REF, (2, 1)), "damped", k_a=125.0, E_rod=np.array([170e9, 169e9]))
    comp = compare(meas, "damped", ev)
    assert comp.predicted[0] == pytest.approx(modes.damped_hz[0, 0], rel=1e-12)
    assert comp.predicted[1] == pytest.approx(modes.natural_hz[1, 0], rel=1e-12)
    assert comp.zeta[0] == pytest.approx(modes.damping_ratio[0, 0], rel=1e-12)
    from eigentwist.cli.compare import to_json

    rows = to_json(comp, [])["rows"]
    assert [r["kind"] for r in rows] == ["damped", "undamped"] and rows[0]["model_damping_ratio"] == comp.zeta[0]


def test_decay_bound():
    """A damped row without a measured ratio costs only where the model's mode grows."""
    from eigentwist.diagnose.damping import DECAY_SIGMA, zeta_residuals, zeta_rows
    from eigentwist.diagnose.measurements import Measurements

    meas = Measurements(np.ones(2), ("x", "y"), np.ones(2), np.ones(2), np.zeros((2, 3)), kind=("damped", "damped"))
    r = zeta_residuals(meas, np.array([-DECAY_SIGMA, DECAY_SIGMA]), zeta_rows(meas))
    np.testing.assert_allclose(r, [-1.0, 0.0])
    # another mode of the row's condition growing costs as much: the oscillation would not decay
    r = zeta_residuals(meas, np.array([DECAY_SIGMA, DECAY_SIGMA]), zeta_rows(meas), least=np.array([-DECAY_SIGMA, 0.0]))
    np.testing.assert_allclose(r, [-1.0, 0.0])
    assert zeta_rows(meas, damped_model=False) is None  # a model without damping: zeta = 0, no residual


def test_synthetic_damped_campaign_recovers_c_a(ev):
    """Damped frequencies of modes x and y over the paper's k_a, c_a = 2 N m s/rad, 1 % noise:
    the fitted c_a lies within 3 sigma; the damping ratios alone (10 % noise) find it too."""
    from eigentwist.diagnose.fit import fit
    from eigentwist.diagnose.measurements import Measurements

    ka = np.repeat([125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0], 2)
    labels = ["x", "y"] * 6
    poses = np.tile(X_REF, (len(ka), 1))
    modes = ev.modes(poses, "damped", k_a=ka, c_a=2.0, vectors=False)
    col = np.tile([0, 1], 6)
    rng = np.random.default_rng(7)
    f = modes.damped_hz[np.arange(len(ka)), col] * (1 + 0.01 * rng.standard_normal(len(ka)))
    meas = Measurements.from_arrays(ka, labels, f, poses=poses, sigma_hz=0.01 * f, ev=ev, kind="damped")
    r = fit(meas, ev.robot.presets["damped"], ev, ("c_a",), start={"c_a": 1.0})
    assert abs(r.values["c_a"] - 2.0) < 3 * r.std["c_a"] < 0.5
    true = modes.damping_ratio[np.arange(len(ka)), col]
    zeta = true * (1 + 0.1 * rng.standard_normal(len(ka)))
    by_zeta = Measurements.from_arrays(
        ka,
        labels,
        modes.natural_hz[np.arange(len(ka)), col],
        poses=poses,
        ev=ev,
        modal={"damping_ratio": zeta, "sigma_damping_ratio": 0.1 * true},
    )
    r = fit(by_zeta, ev.robot.presets["damped"], ev, ("c_a",), start={"c_a": 1.0})
    assert abs(r.values["c_a"] - 2.0) < 3 * r.std["c_a"] < 0.5
    assert r.n == 2 * len(ka)  # frequencies and damping ratios


def test_coupled_plates_match_the_split_compliance_at_home(ev):
    """At x_ref the plates' couplings (ee_coupling: massless plate coordinates condensed,
    the rigid legs' internal equations a singular pencil) and the paper's split compliance
    (ee_compliance) give the same lateral modes, damped as well (1e-6)."""
    a = ev.modes(X_REF, "actuator_loss,ee_coupling,servo_damping", k_a=125.0)
    b = ev.modes(X_REF, "actuator_loss,ee_compliance,servo_damping", k_a=125.0)
    assert a.stable.all() and b.stable.all()
    np.testing.assert_allclose(a.damping.poles[0, :2], b.damping.poles[0, :2], rtol=1e-6)


def test_plot_titles_carry_zeta(ev):
    from eigentwist.plots.animate import modes_svg
    from eigentwist.plots.robot import damped_text as _damped

    low = ev.modes(X_REF, "damped", k_a=125.0)
    assert _damped(low, 0) == f", zeta {low.damping_ratio[0, 0]:.2g}, damped {low.damped_hz[0, 0]:.4g} Hz"
    assert "zeta 0.43" in _damped(low, 0) and _damped(ev.modes(X_REF, "paper"), 0) == ""
    assert "zeta 0.43, damped 5.282 Hz" in modes_svg(ev, X_REF, "damped", k_a=125.0, n_modes=1)  # the report's


def test_cli_synth_writes_damped_frequencies(capsys):
    from eigentwist.cli.main import main

    assert (
        main(
            [
                "synth",
                "--truth",
                "paper+servo_damping:c_a=2",
                "--k-a",
                "125",
                "--modes",
                "x",
                "--kind",
                "damped",
                "--noise",
                "0",
                "--sigma",
                "1%",
            ]
        )
        == 0
    )
    row = capsys.readouterr().out.splitlines()[1].split(",")
    ev = __import__("eigentwist").load("heli4", backend="numpy")
    assert row[4] == "damped"
    assert float(row[2]) == pytest.approx(
        ev.modes(X_REF, "paper,servo_damping", k_a=125.0, c_a=2.0).damped_hz[0, 0], rel=1e-9
    )


def test_workspace_map_of_a_damped_model(ev):
    """The report's map: the lowest damped frequency below the lowest undamped one, and the
    least damping ratio no larger than the lowest mode's."""
    from eigentwist.report.figures import lowest_frequency_map

    m = lowest_frequency_map(ev, "damped", X_REF, 125.0, {}, grid=2)
    lowest = ev.modes(np.array([[m["x"][0], m["y"][0], X_REF[2]]]), "damped", k_a=125.0)
    assert m["f1_damped"][0, 0] == pytest.approx(np.min(lowest.damped_hz), rel=1e-12)
    assert np.all(m["f1_damped"] < m["f1"]) and np.all(m["zeta_min"] <= lowest.damping_ratio[0, 0])
    assert "f1_damped" not in lowest_frequency_map(ev, "paper", X_REF, 125.0, {}, grid=2)


def test_pencil_against_qz():
    """The legs' coupled internal equations with an algebraic coordinate (singular E): the
    pencil A v = s B v by scipy's QZ pose by pose; its infinite eigenvalue is no pole."""
    from scipy.linalg import eig

    from eigentwist.runtime.damped import NO_POLE, _pencil_eig

    rng = np.random.default_rng(5)
    N, m = 4, 6
    A = rng.normal(size=(N, m, m)) + 3 * np.eye(m)
    B = np.broadcast_to(np.diag([1.0, 1.0, 1.0, 1.0, 1.0, 0.0]), (N, m, m))
    s, V = _pencil_eig(A, B, np.full(N, 1e9), np.ones(N, dtype=bool))
    for k in range(N):
        w = eig(A[k], B[k], right=False)
        finite = np.sort_complex(w[np.isfinite(w)])
        np.testing.assert_allclose(np.sort_complex(s[k][s[k] != -NO_POLE]), finite, rtol=1e-10)
        assert np.sum(s[k] == -NO_POLE) == 1
        inf = s[k] == -NO_POLE  # its vector: B v = 0; the others A v = s B v
        np.testing.assert_allclose((A[k] @ V[k])[:, ~inf], (B[k] @ V[k] * s[k])[:, ~inf], atol=1e-9)
        np.testing.assert_allclose((B[k] @ V[k])[:, inf], 0.0, atol=1e-9)
