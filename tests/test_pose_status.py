"""What a user's description file may leave out, and each pose's status said.

* legs without checks (``checks=()``, the default) evaluate; a check of any name is honoured
  (a strut's stroke: unreachable past it, the strut length from the geometry in the test);
* a ``SerialLeg`` with a virtual joint after its final spherical joint builds its six unit
  twists (the virtual one checked against the rotation it stands for);
* the old imports ``eigentwist.symbolic.screw`` and ``eigentwist.runtime.chain.ChainEvaluator``
  work and warn; ``"none"`` is named among the models;
* parallel singularities: the 3-RPS with every leg in the base plane (z = 0) and a 3-RPR with
  radial struts at home are refused (``SingularPoseError``), said by ``pose_status``, NaN
  and invalid in batches, and mapped by a sweep's status column; the conditioning equals an
  independent one from the struts' lines in Pluecker coordinates, and the threshold is met
  on both sides of it;
* design studies name the masses and inertias they hold fixed while lengths move.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import eigentwist
from eigentwist.runtime.errors import SingularPoseError, UnreachablePoseError
from eigentwist.runtime.validity import CONDITIONING_TOL

DESCRIPTIONS = Path(__file__).resolve().parent / "descriptions"


@pytest.fixture(scope="module")
def rpr():
    """The planar 3-RPR (legs without checks), NumPy backend, generated once into the cache."""
    return eigentwist.load(str(DESCRIPTIONS / "rpr3.py"), backend="numpy", progress=None)


@pytest.fixture(scope="module")
def rps():
    """The 3-RPS (a check named ``stroke``), NumPy backend."""
    return eigentwist.load(str(DESCRIPTIONS / "rps3.py"), backend="numpy", progress=None)


# ---------------------------------------------------------------- the user file's traps
def test_legs_without_checks_evaluate(rpr):
    f = rpr.frequencies([0.0, 0.0, 0.3], "none")[0]
    assert np.isfinite(f).all() and f[0] > 0
    assert abs(f[1] - f[2]) <= 1e-9 * f[2]  # threefold symmetry: x and y alike
    assert rpr.valid([[0.0, 0.0, 0.3], [0.01, -0.02, 0.2]]).all()


def test_a_check_of_any_name_is_honoured(rps):
    """The strut reaches s_max = 0.6 m at z = sqrt(0.6^2 - (R_b - R_p)^2) (untilted platform)."""
    z_max = np.sqrt(0.6**2 - 0.15**2)
    inside, outside = [z_max - 1e-6, 0, 0], [z_max + 1e-6, 0, 0]
    assert rps.valid([inside, outside]).tolist() == [True, False]
    with pytest.raises(UnreachablePoseError, match=r"leg 1: the leg's check 'stroke' left \[-1, 1\]"):
        rps.frequencies(outside)
    assert rps.pose_status([inside, outside])["status"].tolist() == ["reachable", "unreachable"]


def test_virtual_joint_after_a_final_spherical_joint():
    """A PRS leg in URDF form: slider along z at (R_b, 0, 0), a revolute joint about y, the rod
    L along the turned z to the spherical joint, then the virtual joint in the spherical
    joint's frame: a rotation about the frame's x axis through the revolute joint."""
    from eigentwist.description.pose import RigidPose
    from eigentwist.description.screw import spatial_inertia
    from eigentwist.description.serial import Body, Joint, SerialLeg
    from eigentwist.symbolic.leg import leg_screws
    from eigentwist.symbolic.program import Program

    L, R_b, s, th = 0.4, 0.3, 0.5, 0.3
    leg = SerialLeg(
        "leg 1",
        joints=(
            Joint("P", origin=(R_b, 0, 0), axes=((0, 0, 1),), actuated=True),
            Joint("R", axes=((0, 1, 0),)),
            Joint("S", origin=(0, 0, L)),
            Joint("virtual", origin=(0, 0, -L), axes=((1, 0, 0),)),
        ),
        bodies=(Body("rod", 2, spatial_inertia(1.0, sp.Matrix([0, 0, L / 2]), sp.diag(0.01, 0.01, 0))),),
        attachment=(0.15, 0, 0),
        reference=(s, th),
    )
    chain = leg.chain_leg()
    pose = RigidPose()
    prog = Program()
    q = tuple(prog.declare(v) for v in chain.kinematics.symbols("1"))
    for v in pose.program_inputs:
        prog.declare(v)
    ls = leg_screws(prog, chain, q, pose, "1")
    values = {
        "q1_1": s,
        "q2_1": th,
        "x": 0.0,
        "y": 0.0,
        "z": 0.0,
        **{f"R_{i}{j}": float(i == j) for i in range(3) for j in range(3)},
    }
    twist = np.array(prog.evaluate(values, sp.Matrix(ls.twists["c"])), dtype=float).ravel()
    axis, point = np.array([np.cos(th), 0, -np.sin(th)]), np.array([R_b, 0, s])
    np.testing.assert_allclose(twist, np.concatenate([axis, np.cross(point, axis)]), atol=1e-14)
    T = np.hstack([np.array(prog.evaluate(values, sp.Matrix(ls.twists[k])), dtype=float) for k in ls.keys])
    assert abs(np.linalg.det(T)) > 1e-3  # six independent twists


def test_the_old_screw_import_warns_and_works():
    from eigentwist.description import screw

    sys.modules.pop("eigentwist.symbolic.screw", None)
    with pytest.warns(DeprecationWarning, match="eigentwist.description.screw"):
        old = importlib.import_module("eigentwist.symbolic.screw")
    assert old.spatial_inertia is screw.spatial_inertia and old.cross is screw.cross


def test_the_old_chain_evaluator_warns_and_loads():
    from eigentwist.runtime.chain import ChainEvaluator

    with pytest.warns(DeprecationWarning, match=r"eigentwist.load\(robot\)"):
        ev = ChainEvaluator("delta", backend="numpy")
    np.testing.assert_array_equal(
        ev.frequencies(ev.robot.x_ref), eigentwist.load("delta", backend="numpy").frequencies(ev.robot.x_ref)
    )


def test_the_models_error_names_none():
    from eigentwist.description.effects import resolve_model

    with pytest.raises(ValueError, match=r"expected one of none, "):
        resolve_model("nonsense", eigentwist.load("delta", backend="numpy").robot)
    assert "`none` = no effect at all" in (Path(__file__).resolve().parents[1] / "README.md").read_text()


# ---------------------------------------------------------------- parallel singularities
def test_rps_with_every_leg_in_the_base_plane_is_parallel_singular(rps):
    with pytest.raises(SingularPoseError, match="parallel singular"):
        rps.frequencies([0.0, 0.0, 0.0], "none")
    st = rps.pose_status([[0.40, 0, 0], [0.0, 0, 0]])
    assert st["status"].tolist() == ["reachable", "parallel singular"]
    assert st["conditioning"][0] > 0.05 and st["conditioning"][1] <= CONDITIONING_TOL
    modes = rps.modes([[0.40, 0, 0], [0.0, 0, 0]], "none", invalid="nan")
    assert modes.valid.tolist() == [True, False] and np.isnan(modes.freq_hz[1]).all()


def _rpr_conditioning(rot_z: float, R_b: float = 0.40, R_p: float = 0.10) -> float:
    """The 3-RPR's conditioning from its struts' lines: each strut's row [r x s; s] (length
    rate of a platform twist [omega; v]: s . (v + omega x r)) at unit length, and an
    orthonormal basis of each leg's constraint wrenches (a force along z through its
    platform joint, moments about x and y)."""
    c, s_ = np.cos(rot_z), np.sin(rot_z)
    rows = []
    for deg in (90, 210, 330):
        er = np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg)), 0.0])
        top = np.array([[c, -s_, 0], [s_, c, 0], [0, 0, 1]]) @ (R_p * er)
        strut = (top - R_b * er) / np.linalg.norm(top - R_b * er)
        act = np.concatenate([np.cross(top, strut), strut])
        rows.append(act / np.linalg.norm(act))
        C = np.array([np.concatenate([np.cross(top, [0, 0, 1]), [0, 0, 1]]), [1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0]])
        rows.extend(np.linalg.qr(C.T)[0].T)
    sv = np.linalg.svd(np.array(rows), compute_uv=False)
    return sv[-1] / sv[0]


def test_radial_rpr_at_home_is_parallel_singular(rpr):
    with pytest.raises(SingularPoseError, match="parallel singular"):
        rpr.frequencies([0.0, 0.0, 0.0], "none")
    st = rpr.pose_status([[0.0, 0.0, 0.0], [0.0, 0.0, 0.3]])
    assert st["status"].tolist() == ["parallel singular", "reachable"]
    assert abs(st["conditioning"][1] - _rpr_conditioning(0.3)) <= 1e-9 * _rpr_conditioning(0.3)


def test_the_parallel_threshold_follows_the_conditioning(rpr):
    """Where the independent conditioning crosses CONDITIONING_TOL (bisection on rot_z), 2 %
    to either side: refused below, evaluated above."""
    lo, hi = 0.0, 1e-3
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _rpr_conditioning(mid) < CONDITIONING_TOL else (lo, mid)
    below, above = [0.0, 0.0, hi / 1.02], [0.0, 0.0, hi * 1.02]
    assert rpr.pose_status([below, above])["status"].tolist() == ["parallel singular", "reachable"]
    assert rpr.valid([below, above]).tolist() == [False, True]
    assert np.isfinite(rpr.frequencies(above, "none")).all()
    with pytest.raises(SingularPoseError):
        rpr.frequencies(below, "none")


@pytest.mark.compiled
@pytest.mark.parametrize("model", ["paper", "rigid"])
def test_the_fused_c_pass_refuses_the_parallel_singularity(model):
    """The Delta with l2 = 0.4 m: at x = y = 0 its three forearms lie horizontal where the
    elbows' radius R + l1 cos q1 reaches r_p + l2, at z = -sqrt(l1^2 - (l2 - R + r_p)^2)
    (the elbows' height): no actuator resists a vertical motion. The fused C pass (flexible
    and rigid models) refuses it as the NumPy path does; its neighbours keep their modes."""
    d = eigentwist.load("delta", backend="numpy").defaults
    z = -np.sqrt(d["l1"] ** 2 - (0.4 - d["R"] + d["r_p"]) ** 2)
    x = np.array([[0.0, 0.0, -0.25], [0.0, 0.0, z], [0.0, 0.0, -0.1]])
    evs = (eigentwist.load("delta", backend="numpy"), eigentwist.load("delta", backend="c", threads=1))
    for ev in evs:
        with pytest.raises(SingularPoseError, match="parallel singular"):
            ev.frequencies(x[1], model, l2=0.4)
        modes = ev.modes(x, model, invalid="nan", l2=0.4)
        assert modes.valid.tolist() == [True, False, True] and np.isnan(modes.freq_hz[1]).all()
    f = [ev.modes(x[[0, 2]], model, l2=0.4).freq_hz for ev in evs]
    np.testing.assert_allclose(f[1], f[0], rtol=1e-9)


@pytest.mark.compiled
def test_the_fused_pass_checks_exactly_the_poses_below_its_screen(monkeypatch):
    """Near the Delta's singularity (l2 = 0.4 m) the lowest frequency falls with the
    distance: of two poses whose f1 / f_max lie either side of PARALLEL_SCREEN (within 10 %
    of each other), the one below gets the exact check and the one above does not (both are
    regular: the check finds them so)."""
    from eigentwist.runtime import c_route

    numpy_ev = eigentwist.load("delta", backend="numpy")
    d = numpy_ev.defaults
    z0 = -np.sqrt(d["l1"] ** 2 - (0.4 - d["R"] + d["r_p"]) ** 2)

    dz = np.geomspace(1e-5, 0.05, 200)  # consecutive distances 4.4 % apart
    f = numpy_ev.frequencies(np.column_stack([0 * dz, 0 * dz, z0 - dz]), "paper", l2=0.4)
    ratio = f.min(axis=1) / f.max(axis=1)
    k = int(np.argmax(ratio > c_route.PARALLEL_SCREEN))
    assert ratio[k - 1] < c_route.PARALLEL_SCREEN < ratio[k] < 1.1 * ratio[k - 1]
    checked = []
    from eigentwist.runtime.checks import PoseChecks

    original = PoseChecks.parallel_ok

    def spy(self, poses, p, rows, strict):
        checked.extend(poses[rows, 2].tolist())
        return original(self, poses, p, rows, strict)

    monkeypatch.setattr(PoseChecks, "parallel_ok", spy)
    ev = eigentwist.load("delta", backend="c", threads=1)
    x = np.array([[0.0, 0.0, z0 - dz[k - 1]], [0.0, 0.0, z0 - dz[k]]])
    assert np.isfinite(ev.frequencies(x, "paper", l2=0.4)).all()
    assert checked == [x[0, 2]]


def test_sweep_maps_the_singular_region(rps):
    from eigentwist.runtime.sweep import evaluate_chunk, make_spec
    from eigentwist.runtime.validity import POSE_STATUS

    spec = make_spec(str(DESCRIPTIONS / "rps3.py"), model="none", grid=(8, 1, 1), box=(0.0, 0.7, 0, 0, 0, 0))
    cols = evaluate_chunk(spec, 0)
    z = cols["pose"][:, 0]
    length = np.hypot(0.15, z)  # untilted: the strut from R_b to R_p, z up
    want = np.where(
        z == 0,
        POSE_STATUS.index("parallel singular"),
        np.where((length < 0.1) | (length > 0.6), POSE_STATUS.index("unreachable"), 0),
    )
    assert cols["status"].tolist() == want.tolist()
    assert cols["reachable"].tolist() == (want == 0).tolist()


def test_matrices_json_has_status_and_conditioning(capsys):
    import json

    from eigentwist.cli.main import main

    assert main(["matrices", "--robot", "delta", "--backend", "numpy", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "reachable" and CONDITIONING_TOL < out["conditioning"] <= 1.0


# ---------------------------------------------------------------- design studies
def test_design_studies_name_the_masses_held_fixed(capsys):
    import json

    from eigentwist.cli.main import main
    from eigentwist.design.fixed import ZERO_SENSITIVITY, held_fixed, zero_mass_lines

    ev = eigentwist.load("delta", backend="numpy")
    fixed = held_fixed(ev, ["l1"], ("actuator_loss",))
    assert {"m_1", "I1_yy", "I_rotor", "m_e"} <= set(fixed) and "l1" not in fixed and "rho" not in fixed
    assert held_fixed(ev, ["m_1"], ()) == []  # no length moves
    rows = [
        dict(name="m_1", unit="kg", dlnf1_dlnp=ZERO_SENSITIVITY * 0.9),
        dict(name="m_e", unit="kg", dlnf1_dlnp=ZERO_SENSITIVITY * 1.1),
    ]
    lines = zero_mass_lines(ev, rows)
    assert len(lines) == 1 and lines[0].startswith("m_1 ranks +0") and "I1_xx, I1_yy, I1_zz" in lines[0]
    assert main(["sensitivity", "--robot", "delta", "--backend", "numpy", "--wrt", "l1,m_1,m_e", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "m_1" in out["held_fixed"] and any(n.startswith("m_1 ranks +0") for n in out["notes"])
