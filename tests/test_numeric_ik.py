"""Inverse kinematics without algebra: legs in URDF form solved by damped Newton.

Expectations come from the closed forms the shipped robots carry (an independent
derivation of the same joint coordinates), not from the Newton code:

* numeric IK equals the closed-form IK on the Heli4, the Delta and the hexapod to 1e-10
  (rad; m for the hexapod's leg lengths), over random poses of each workspace box;
* Newton converges from the reference configuration over the whole box (a grid);
* an unreachable pose is reported (status, one-line message), never a wrong configuration;
* joint coordinates given as input (``joints=``) give what the pose gives;
* the hexapod in URDF form has the shipped hexapod's model (frequencies to 1e-9);
* the README's joint-list file loads through ``eigentwist.load(PATH)`` and ``--robot PATH``;
* compiled tier: the C loop-closure kernel equals the NumPy one, and so do the solutions.
"""

from __future__ import annotations

import ctypes
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import eigentwist
from eigentwist.runtime.errors import InputError, UnreachablePoseError

from .c_signatures import check
from .conftest import random_poses, skip_tier, workspace_grid
from .descriptions import hexapod_urdf, rrpirr_urdf

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def numeric():
    """NumPy evaluators of the shipped robots with their legs in URDF form (generated once
    into the cache) and of the shipped robots themselves."""
    robots = {"heli4": rrpirr_urdf.heli4(), "delta": rrpirr_urdf.delta(), "hexapod": hexapod_urdf.describe()}
    return {
        name: (eigentwist.load(robot, backend="numpy", progress=lambda m: None), eigentwist.load(name, backend="numpy"))
        for name, robot in robots.items()
    }


def _closed_coordinates(name: str, q_numeric: np.ndarray) -> np.ndarray:
    """The numeric solution's coordinates that the closed form reports: q1, q2, q3 of an
    RR(Pi)RR leg (R, R, Pi come first), the strut length (the P joint after the U's two)."""
    return q_numeric[:, :, 2:3] if name == "hexapod" else q_numeric[:, :, :3]


@pytest.mark.parametrize("name", ["heli4", "delta", "hexapod"])
def test_numeric_ik_equals_closed_form(numeric, name):
    ev, shipped = numeric[name]
    poses = random_poses(shipped.robot, 60, seed=21)
    q = ev.joint_angles(poses)
    assert np.isfinite(q).all()
    assert np.abs(_closed_coordinates(name, q) - shipped.joint_angles(poses)).max() < 1e-10
    if name == "hexapod":  # a geometric parameter per pose: each pose solved with its own
        r_p = np.linspace(0.95, 1.05, 60) * shipped.defaults["R_p"]
        q = ev.joint_angles(poses, R_p=r_p)
        assert np.abs(_closed_coordinates(name, q) - shipped.joint_angles(poses, R_p=r_p)).max() < 1e-10


@pytest.mark.parametrize("name", ["heli4", "delta", "hexapod"])
def test_newton_converges_over_the_workspace_box(numeric, name):
    """Over a grid of the box, in one batch and pose by pose (no warm start)."""
    ev, shipped = numeric[name]
    grid = workspace_grid(shipped.robot, 3 if name == "hexapod" else 5)
    assert shipped.valid(grid).all()
    q = ev.joint_angles(grid)
    assert np.isfinite(q).all()
    assert np.abs(_closed_coordinates(name, q) - shipped.joint_angles(grid)).max() < 1e-10
    # each pose alone in its batch (no warm start): from the reference configuration only
    alone = grid if len(grid) <= 125 else grid[np.random.default_rng(0).choice(len(grid), 80, replace=False)]
    q_alone = np.concatenate([ev.joint_angles(pose) for pose in alone])
    assert np.abs(_closed_coordinates(name, q_alone) - shipped.joint_angles(alone)).max() < 1e-10


def test_unreachable_pose_is_reported(numeric):
    ev, shipped = numeric["heli4"]
    far = np.array([[0.0, 0.0, -1.2], [0.0, 0.0, -0.625], [0.6, 0.0, -0.6]])
    assert not shipped.valid(far[[0, 2]]).any()  # beyond the legs' reach
    assert ev.valid(far).tolist() == [False, True, False]
    q = ev.joint_angles(far[1:2])
    assert np.isfinite(q).all()
    with pytest.raises(UnreachablePoseError) as info:
        ev.frequencies(far[:1])
    message = str(info.value)
    assert "\n" not in message and "unreachable" in message and "closure" in message
    modes = ev.modes(far, "rigid", invalid="nan")
    assert modes.valid.tolist() == [False, True, False]
    assert np.isnan(modes.freq_hz[[0, 2]]).all() and np.isfinite(modes.freq_hz[1]).all()


def test_unreachable_rows_do_not_spoil_their_neighbours(numeric):
    """A batch mixing reachable and unreachable poses: the reachable ones solve as alone."""
    ev, shipped = numeric["delta"]
    poses = np.array([[0.0, 0.0, -0.75], [0.0, 0.0, -2.0], [0.1, -0.1, -0.8], [0.15, 0.1, -0.65]])
    q = ev.joint_angles(poses[[0, 2, 3]])
    assert np.abs(q[:, :, :3] - shipped.joint_angles(poses[[0, 2, 3]])).max() < 1e-10
    assert ev.valid(poses).tolist() == [True, False, True, True]


def test_hexapod_in_urdf_form_has_the_shipped_model(numeric):
    ev, shipped = numeric["hexapod"]
    poses = random_poses(shipped.robot, 20, seed=5)
    for model in ("none", "paper"):
        a, b = ev.frequencies(poses, model), shipped.frequencies(poses, model)
        assert np.abs(a - b).max() / b.max() < 1e-9
    ma, mb = ev.matrices(poses), shipped.matrices(poses)
    for k in ("M", "K_R", "K_F"):
        assert np.abs(ma[k] - mb[k]).max() <= 1e-9 * np.abs(mb[k]).max()


@pytest.mark.parametrize("name", ["heli4", "hexapod", "hexapod_urdf"])
def test_joint_coordinates_in_equal_pose_in(numeric, name):
    ev = numeric["hexapod"][0] if name == "hexapod_urdf" else numeric[name][1]
    poses = random_poses(numeric["hexapod" if "hexapod" in name else name][1].robot, 8, seed=3)
    q = ev.joint_angles(poses)
    by_pose = ev.frequencies(poses)
    at_joints = ev.frequencies(poses, joints=q)
    assert np.abs(at_joints - by_pose).max() <= 1e-12 * by_pose.max()
    ma, mj = ev.matrices(poses, "rigid"), ev.matrices(poses, "rigid", joints=q)
    for k in ma:
        assert np.abs(ma[k] - mj[k]).max() <= 1e-12 * np.abs(ma[k]).max()
    modes = ev.modes(poses, joints=q)
    assert np.abs(modes.freq_hz - by_pose).max() <= 1e-12 * by_pose.max()
    if ev.dof == 3:  # a translational model reads the joints only
        assert np.array_equal(ev.frequencies(None, joints=q), at_joints)


def test_joint_coordinates_bad_input(numeric):
    ev = numeric["hexapod"][1]
    with pytest.raises(InputError, match=r"joints has shape \(2, 6, 3\): expected \(N, 6, 1\)"):
        ev.frequencies(np.zeros((2, 6)), joints=np.zeros((2, 6, 3)))
    with pytest.raises(InputError, match="reads the pose too"):
        ev.frequencies(None, joints=np.full((1, 6, 1), 0.8))
    with pytest.raises(InputError, match="not finite"):
        ev.frequencies([0, 0, 0.8, 0, 0, 0], joints=np.full((1, 6, 1), np.nan))


# ----------------------------------------------------- the README's joint-list file
def _readme_file(name: str) -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(rf"<!-- description file: {re.escape(name)} -->\s*```python\n(.*?)```", text, re.S)
    assert m, f"README.md has no description file block {name}"
    return m.group(1)


@pytest.fixture(scope="session")
def readme_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("readme") / "my_hexapod.py"
    path.write_text(_readme_file("my_hexapod.py"))
    return path


def test_readme_joint_list_file_loads(readme_file, numeric):
    ev = eigentwist.load(str(readme_file), backend="numpy", progress=lambda m: None)
    shipped = numeric["hexapod"][1]
    poses = random_poses(shipped.robot, 5, seed=8)
    a, b = ev.frequencies(poses, "none"), shipped.frequencies(poses, "none")
    assert np.abs(a - b).max() / b.max() < 1e-9
    # the same file through the command line's --robot door
    cmd = [
        sys.executable,
        "-m",
        "eigentwist",
        "matrices",
        "--robot",
        str(readme_file),
        "--pose",
        "0",
        "0",
        "0.8",
        "0",
        "0",
        "0",
        "--model",
        "none",
    ]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "62.27" in run.stdout or "62.3" in run.stdout


# ---------------------------------------------------------------- compiled tier
@pytest.mark.compiled
def test_c_loop_closure_equals_numpy(numeric):
    from eigentwist.runtime import ccompile

    try:
        ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    ev, _ = numeric["hexapod"]
    evc = eigentwist.load(hexapod_urdf.describe(), backend="c", progress=lambda m: None)
    poses = random_poses(ev.robot, 30, seed=2)
    rng = np.random.default_rng(0)
    q = ev.joint_angles(poses) + 0.05 * rng.standard_normal((30, 6, 3))
    p = {**ev.parameter_values(30), **ev.kernel_pose_inputs(poses)}
    a = ev.module.loop_closure(q, p)
    b = evc._kernels.loop_closure(q, p)  # the compiled kernel itself
    for k in ("residual", "dresidual"):
        assert np.allclose(a[k], b[k], rtol=1e-12, atol=1e-14)
    assert np.abs(evc.joint_angles(poses) - ev.joint_angles(poses)).max() < 1e-12
    # the Newton iterations in C (c_levenberg_marquardt) and in NumPy around the same compiled closure
    from eigentwist.runtime import c_levenberg_marquardt

    assert c_levenberg_marquardt.driver() is not None
    full, pc = evc.completion.poses(poses), evc.parameter_values(30)
    in_c = evc.solve_joints(full, pc)
    evc.c_newton = False
    evc.completion._newton_memo.clear()  # solved again, in NumPy
    in_numpy = evc.solve_joints(full, pc)
    evc.c_newton = True
    assert in_numpy is not in_c
    # ranges of blocks on two threads (from 2 x 16 blocks of 64 poses): the same iterations, bit for bit
    from eigentwist.runtime.threads import MIN_BLOCKS_PER_THREAD, threads_for

    n = 2 * MIN_BLOCKS_PER_THREAD * 64
    assert threads_for(n, 64, 2) == 2
    many = random_poses(ev.robot, n, seed=4)
    kp = evc.closure_inputs(many, evc.parameter_values(n))
    start = np.broadcast_to([leg.kinematics.reference for leg in evc.robot.legs], (n, 6, 3))
    one, two = evc.kernels.newton(start, kp, 80, 1e-12), evc.kernels.newton(start, kp, 80, 1e-12, threads=2)
    assert np.array_equal(one[0], two[0], equal_nan=True) and np.array_equal(one[1], two[1], equal_nan=True)
    # the closure's block function in the driver's own buffers against the exported kernel (gathered,
    # scattered, copied): the same iterations bit for bit, on a whole block and a short one (5 poses)
    spec = evc.kernels._spec["loop_closure"]
    k69 = evc.closure_inputs(many[:69], evc.parameter_values(69))
    by_block = evc.kernels.newton(start[:69], k69, 80, 1e-12)
    block = spec.pop("block")
    try:
        by_kernel = evc.kernels.newton(start[:69], k69, 80, 1e-12)
    finally:
        spec["block"] = block
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(by_block, by_kernel))
    # the branch check's jacobians kernel on the same ranges: the same levers, bit for bit
    lever = evc.kernels.jacobians(one[0], kp)["lever"]
    assert np.array_equal(evc.kernels.jacobians(one[0], kp, threads=2)["lever"], lever, equal_nan=True)
    assert np.isfinite(in_c).all() and np.abs(in_c - in_numpy).max() < 1e-12
    fa, fc = ev.frequencies(poses), evc.frequencies(poses)
    assert np.abs(fa - fc).max() / fa.max() < 1e-12


# ------------------------------------------------- joint coordinates in the measurement CSV
def test_measurement_csv_joint_columns(numeric):
    from eigentwist.diagnose.measurements import MeasurementError, joint_columns, parse_csv
    from eigentwist.diagnose.predict import Predictor

    ev = numeric["heli4"][1]
    poses = np.array([[0.0, 0.0, -0.625], [0.05, -0.03, -0.6]])
    q = ev.joint_angles(poses)
    cols = joint_columns(ev)
    assert cols[:4] == ("q1@1", "q2@1", "q3@1", "q1@2") and len(cols) == 12
    rows = ["k_a,mode,freq_hz,x,y,z," + ",".join(cols)]
    for pose, qq in zip(poses, q):
        for mode in ("x", "y"):
            rows.append(f"2000,{mode},20.0," + ",".join(repr(float(v)) for v in (*pose, *qq.ravel())))
    with_joints = parse_csv("\n".join(rows) + "\n", "enc.csv", ev)
    assert with_joints.joints.shape == (4, 4, 3)
    assert np.array_equal(with_joints.joints[2], q[1])
    without = parse_csv("\n".join(r.rsplit(",", 12)[0] for r in rows) + "\n", "pose.csv", ev)
    assert without.joints is None
    a = Predictor(with_joints, ("actuator_loss",), ev).predict()[0]
    b = Predictor(without, ("actuator_loss",), ev).predict()[0]
    assert np.abs(a - b).max() <= 1e-12 * b.max()
    # shifted encoder readings move the prediction: the columns are used, not ignored
    shifted = parse_csv(
        "\n".join(rows).replace(repr(float(q[0, 0, 0])), repr(float(q[0, 0, 0]) + 0.01)) + "\n", "shift.csv", ev
    )
    assert np.abs(Predictor(shifted, ("actuator_loss",), ev).predict()[0][:2] - b[:2]).max() > 1e-3
    with pytest.raises(MeasurementError, match="'q3@4' is missing"):
        parse_csv("\n".join(r.rsplit(",", 1)[0] for r in rows) + "\n", "cut.csv", ev)


# ------------------------------------------------------------ the solver on its own
def _two_link(poses, l1=1.0, l2=0.8):
    """Loop closure of a planar two-link arm reaching (x, y): an independent NumPy model."""

    def closure(q, p):
        a, b = q[..., 0], q[..., 1]
        r = np.stack(
            [
                l1 * np.cos(a) + l2 * np.cos(a + b) - p["x"][:, None],
                l1 * np.sin(a) + l2 * np.sin(a + b) - p["y"][:, None],
            ],
            -1,
        )
        A = np.stack(
            [
                np.stack([-l1 * np.sin(a) - l2 * np.sin(a + b), -l2 * np.sin(a + b)], -1),
                np.stack([l1 * np.cos(a) + l2 * np.cos(a + b), l2 * np.cos(a + b)], -1),
            ],
            -2,
        )
        return {"residual": r, "dresidual": A}

    return closure, {"x": poses[:, 0], "y": poses[:, 1]}


@pytest.mark.parametrize("elbow", [1.0, -1.0])
def test_newton_keeps_the_descriptions_branch(elbow):
    """The elbow sign of the reference configuration is the solution's (law of cosines),
    and an unreachable target gives NaN, never a nearby configuration."""
    from eigentwist.runtime.levenberg_marquardt import solve

    rng = np.random.default_rng(4)
    radius = rng.uniform(0.3, 1.7, 200)
    angle = rng.uniform(-0.6, 1.2, 200)  # the arm's workspace: a sector about the reference
    poses = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    poses = np.vstack([poses, [[2.5, 0.0]], [[0.05, 0.0]]])  # out of reach: too far, too close
    closure, p = _two_link(poses)
    q = solve(closure, np.array([[0.3, 1.2 * elbow]]), p, len(poses), branch=lambda q: np.sin(q[..., 1]))
    cos_b = (radius**2 - 1.0 - 0.64) / (2 * 0.8)
    assert np.all(np.isfinite(q[:200]))
    b = q[:200, 0, 1]
    assert np.abs(np.cos(b) - cos_b).max() < 1e-10 and (np.sign(np.sin(b)) == elbow).all()
    assert np.isnan(q[200:]).all()


def test_homotopy_keeps_the_references_elbow_where_newton_jumps():
    """From a reference far from closing, plain Newton closes the two-link arm on the other
    elbow; the homotopy from the reference (the branch recorded at x_ref) keeps its elbow
    (law of cosines for the angle, the sign of sin b for the elbow)."""
    from eigentwist.runtime.levenberg_marquardt import continuation, solve

    target = np.array([[-0.59, -0.14]])
    reference = np.array([[-1.02, 1.73]])  # elbow +: sin(1.73) > 0
    closure, p = _two_link(target)
    jumped = solve(closure, reference, p, 1)[0, 0]
    kept, residual = continuation(closure, reference, p)
    cos_b = (np.sum(target**2) - 1.0 - 0.64) / (2 * 0.8)
    for q in (jumped, kept[0]):
        assert abs(np.cos(q[1]) - cos_b) < 1e-10
    assert np.sin(jumped[1]) < 0 < np.sin(kept[0, 1]) and residual[0] < 1e-12


@pytest.mark.parametrize("factor, follows", [(0.9, True), (1.1, False)])
def test_homotopy_follows_its_path_within_path_tol(factor, follows):
    """Two residuals of one coordinate that disagree by 2f, r = [q - a, q - a - 2f]: the
    homotopy's target (1 - t) r(q_ref) is met to f t sqrt(2) at best (least squares), so the
    path ends at f sqrt(2): followed just below PATH_TOL, lost (NaN) just above it."""
    from eigentwist.runtime.levenberg_marquardt import PATH_TOL, continuation

    a, f = 0.4, factor * PATH_TOL / np.sqrt(2)

    def closure(q, p):
        r = np.concatenate([q - a, q - a - 2 * f], axis=-1)
        return {"residual": r, "dresidual": np.ones(q.shape[:-1] + (2, 1))}

    q, _ = continuation(closure, np.array([[1.3]]), {})
    assert np.isfinite(q).all() == follows
    if follows:
        assert abs(q[0, 0] - (a + f)) < 1e-12


def test_two_configurations_are_one_within_the_branch_gap():
    from eigentwist.runtime.levenberg_marquardt import BRANCH_GAP, same_configuration

    a = np.array([0.3, -2.0, 0.8])  # rad, rad, m
    angular = np.array([True, True, False])
    for k in range(3):
        step = np.eye(3)[k]
        assert same_configuration(a + 0.9 * BRANCH_GAP * step, a, angular)
        assert not same_configuration(a + 1.1 * BRANCH_GAP * step, a, angular)
    assert same_configuration(a + [2 * np.pi, -2 * np.pi, 0], a, angular)  # a turn is the same joint
    assert not same_configuration(a + [0, 0, 2 * np.pi], a, angular)  # a length is not an angle
    assert not same_configuration(a + [np.nan, 0, 0], a, angular)


def test_content_hash_sees_the_urdf_data():
    """Two URDF-form robots that differ only in a joint origin are cached apart."""
    import dataclasses

    from eigentwist.description.serial import SerialLeg
    from eigentwist.runtime.userfile import description_key

    a = rrpirr_urdf.delta()
    leg = a.legs[0].kinematics.leg
    joints = list(leg.joints)
    joints[1] = dataclasses.replace(joints[1], origin=(0.3, 0, 0))
    moved = SerialLeg(leg.name, tuple(joints), leg.bodies, leg.attachment, leg.reference, leg.attachment_rotation)
    b = dataclasses.replace(a, legs=(moved,) + a.legs[1:])
    assert description_key(a) != description_key(b)
    assert description_key(a) == description_key(rrpirr_urdf.delta())


def test_newton_memo_keys_every_input(numeric):
    """Two calls that differ only in a parameter whose name starts with q (a rod length
    ``q_rod``) solve anew: the closure r(q) = q - q_rod has the solution q = q_rod."""
    import copy

    ev = copy.copy(numeric["heli4"][0])
    nq = len(ev.robot.legs[0].kinematics.coordinates)

    class Kernels:
        OUTPUTS: dict = {}  # no lever kernel: the branch check reads jacobians' levers

        @staticmethod
        def loop_closure(q, p):
            r = q - np.asarray(p["q_rod"], dtype=float).reshape(-1, 1, 1)
            return {"residual": r, "dresidual": np.broadcast_to(np.eye(nq), r.shape + (nq,)).copy()}

        @staticmethod
        def jacobians(q, p):
            return {"lever": np.ones(q.shape[:2])}

    from eigentwist.runtime.completion import PoseCompletion

    assembly = ev.assembly()
    ev.completion = PoseCompletion(ev.robot, ev.module, ev.resolver, lambda: Kernels, lambda: None)
    ev.completion.__dict__["_assembly"] = {**assembly, "sign": np.ones(ev.n_legs)}  # the fake lever's branch
    ev.completion.__dict__["_predictor"] = None  # Newton from the reference (the fake reads no default q_rod)
    poses = np.zeros((3, 3))
    for rod in (0.10, 0.20, 0.20, 0.15):
        q = ev.solve_joints(poses, {"q_rod": np.asarray(rod)})
        assert np.abs(q - rod).max() < 1e-12
    # the joint coordinates it adds itself (every leg's, every coordinate's) do not change the key
    p = {"q_rod": np.asarray(0.3)}
    first = ev.solve_joints(poses, p)
    joints = {f"q{m + 1}_{i + 1}": np.zeros(3) for i in range(ev.n_legs) for m in range(nq)}
    assert ev.solve_joints(poses, {**p, **joints}) is first
    # the same bytes as another dtype (an integer: 4.6e18, out of reach) or shape are another input
    q = ev.solve_joints(poses, {"q_rod": np.asarray(0.3).view(np.int64)})
    assert not (np.abs(q - 0.3) < 1e-6).any()
    first = ev.solve_joints(poses, {"q_rod": np.full(3, 0.3)})
    assert ev.solve_joints(poses, {"q_rod": np.full((3, 1), 0.3)}) is not first


@pytest.mark.parametrize("systems", [1, 63, 64, 300])
def test_damped_step_solves_the_normal_equations(systems):
    """Both ways of solving (LAPACK below SOA_MIN systems, entry by entry from it) give
    the damped Gauss-Newton step, checked by its defining equation."""
    from eigentwist.runtime.levenberg_marquardt import SOA_MIN, normal_solve

    assert SOA_MIN == 64
    rng = np.random.default_rng(systems)
    for rows, nq in ((3, 3), (6, 5)):
        A = rng.normal(size=(systems, rows, nq))
        r = rng.normal(size=(systems, rows))
        lam = 10.0 ** rng.uniform(-6, 1, systems)
        step = normal_solve(A, r, lam, 1e-12 * lam)
        AtA = np.einsum("nri,nrj->nij", A, A)
        H = AtA + np.einsum("n,nij->nij", lam, np.einsum("nii->ni", AtA)[:, :, None] * np.eye(nq) + 1e-12 * np.eye(nq))
        assert np.abs(np.einsum("nij,nj->ni", H, step) + np.einsum("nri,nr->ni", A, r)).max() < 1e-11
    # a system whose matrix is not finite gets a non-finite step (the caller rejects it);
    # the others are untouched
    bad = A.copy()
    bad[0, 0, 0] = np.inf
    again = normal_solve(bad, r, lam, 1e-12 * lam)
    assert not np.isfinite(again[0]).all()
    assert np.array_equal(again[1:], step[1:])


def test_the_c_driver_steps_solve_the_normal_equations_for_every_size():
    """The C driver's steps of one block (a fixed-size version for the common leg sizes, the
    general loop for the others) for every size it takes, damped and undamped, checked by
    their defining equation; a lane whose matrix is not finite takes the gradient step -A^T r
    and leaves the others alone; sizes it does not take are refused, naming them."""
    from eigentwist.runtime import c_levenberg_marquardt as clm

    if clm.driver() is None:
        skip_tier("compiled", "no C compiler: the Newton driver's steps cannot be built")
    rng = np.random.default_rng(7)
    n = clm.BLOCK
    for rows in range(1, 8):
        for nq in range(1, 9):
            A = rng.normal(size=(n, rows, nq))
            r = rng.normal(size=(n, rows))
            lam = 10.0 ** rng.uniform(-6, 1, n)
            AtA = np.einsum("nri,nrj->nij", A, A)
            Atr = np.einsum("nri,nr->ni", A, r)
            damped = AtA + np.einsum(
                "n,nij->nij", lam, np.einsum("nii->ni", AtA)[:, :, None] * np.eye(nq) + 1e-12 * np.eye(nq)
            )
            cases = [(lam, 1e-12, damped)] + ([(None, 1e-300, AtA)] if rows >= nq else [])
            for scale, shift, H in cases:
                step = clm.block_steps(A, r, scale, shift)
                scale_of = np.abs(H).max((1, 2)) * np.abs(step).max(1) + np.abs(Atr).max(1)
                residual = np.abs(np.einsum("nij,nj->ni", H, step) + Atr).max(1)
                assert (residual < 1e-13 * scale_of).all(), (rows, nq, scale is None)
    bad = A.copy()
    bad[3, 0, 0] = np.inf
    again = clm.block_steps(bad, r, lam, 1e-12)
    gradient = -np.einsum("ri,r->i", bad[3], r[3])
    finite = np.isfinite(gradient)
    assert np.array_equal(again[3][~finite], gradient[~finite])
    bound = 1e-14 * np.einsum("ri,r->i", np.abs(bad[3]), np.abs(r[3]))  # a sum's round-off
    assert (np.abs(again[3][finite] - gradient[finite]) <= bound[finite]).all()
    assert np.array_equal(np.delete(again, 3, 0), np.delete(clm.block_steps(A, r, lam, 1e-12), 3, 0))
    check(clm.SOURCE, "et_block_steps", clm._LIBRARIES[0].et_block_steps.argtypes, ctypes.c_int)
    with pytest.raises(InputError, match="n_q=9"):
        clm.block_steps(rng.normal(size=(n, 3, 9)), rng.normal(size=(n, 3)), lam, 1e-12)
    with pytest.raises(InputError, match="64 systems, got 63"):
        clm.block_steps(A[:63], r[:63], lam[:63], 1e-12)


def _two_branch_closure(q, p):
    """r(q) = q^2 - x per leg and coordinate: the branches q = +sqrt(x) and -sqrt(x)."""
    x = np.asarray(p["x"], dtype=float).reshape(-1, 1, 1)
    r = q * q - x
    return {"residual": r, "dresidual": (2 * q)[..., None]}


def test_newton_from_a_guess_falls_back_to_the_reference():
    """A first guess only changes the iterations: one on the other branch, or one that does
    not converge, is solved again from the reference, so the answer is the reference's."""
    from eigentwist.runtime.levenberg_marquardt import solve

    x = np.array([0.5, 2.0, 3.0, 4.0])
    p = {"x": x}
    reference = np.ones((1, 1))  # the + branch

    def branch(q):
        return np.sign(q[..., 0])

    calls = []

    def counted(q, pp):
        calls.append(len(q))
        return _two_branch_closure(q, pp)

    plain = solve(counted, reference, p, 4, branch=branch)
    from_reference = len(calls)
    assert np.allclose(plain[:, 0, 0], np.sqrt(x), rtol=0, atol=1e-12)
    calls.clear()
    near = solve(counted, reference, p, 4, branch=branch, start=np.sqrt(x)[:, None, None] + 1e-3)
    assert np.allclose(near, plain, rtol=0, atol=1e-14)
    assert len(calls) < from_reference  # fewer iterations from a good guess
    wrong = np.where(np.arange(4) % 2 == 0, -np.sqrt(x), np.nan)[:, None, None]  # other branch; NaN
    q, off = solve(_two_branch_closure, reference, p, 4, branch=branch, start=wrong, report=True)
    assert np.allclose(q, plain, rtol=0, atol=1e-14)
    assert not off.any()
    # without the fall-back the guesses would have given the other branch
    assert (solve(_two_branch_closure, -reference, p, 4)[::2, 0, 0] < 0).all()


def test_a_pose_whose_guess_jumps_branch_is_warm_started_when_the_reference_fails():
    """From a singular reference (q = 0: no step) nothing converges; a pose whose guess lands
    on the other branch is solved again from the reference, then from the previous pose's
    solution, as a pose without a guess would be."""
    from eigentwist.runtime.levenberg_marquardt import solve

    x = np.array([2.0, 2.5, 3.0])
    start = np.array([np.sqrt(2.0), -np.sqrt(2.5), np.nan])[:, None, None]
    q, off = solve(
        _two_branch_closure,
        np.zeros((1, 1)),
        {"x": x},
        3,
        branch=lambda q: np.sign(q[..., 0]),
        signs=[1.0],
        start=start,
        report=True,
    )
    np.testing.assert_allclose(q[:, 0, 0], np.sqrt(x), rtol=0, atol=1e-14)
    assert not off.any()


def test_a_pose_still_on_the_other_branch_after_the_reference_is_rejected():
    """The branch recorded at x_ref (+) need not be the reference's own: a guess and the
    reference both closing on the - branch leave the pose off its branch, NaN."""
    from eigentwist.runtime.levenberg_marquardt import solve

    x = np.array([2.0, 3.0])
    q, off = solve(
        _two_branch_closure,
        -np.ones((1, 1)),
        {"x": x},
        2,
        branch=lambda q: np.sign(q[..., 0]),
        signs=[1.0],
        start=np.array([np.sqrt(2.0), -np.sqrt(3.0)])[:, None, None],
        report=True,
    )
    assert off[:, 0].tolist() == [False, True]
    assert np.isclose(q[0, 0, 0], np.sqrt(2.0), rtol=0, atol=1e-14) and np.isnan(q[1]).all()


def test_iterations_from_a_guess_start_nearly_undamped():
    """Iterations from a guess start at GUESS_LAMBDA0 (near the solution, Gauss-Newton's
    quadratic convergence), those from the reference at LAMBDA0; from the guess the
    undamped start takes fewer closure calls for the same solution."""
    from eigentwist.runtime import levenberg_marquardt as lm

    assert lm.GUESS_LAMBDA0 < lm.LAMBDA0
    x = np.linspace(1.5, 3.0, 5)
    p = {"x": x}
    used = []

    def iterate(q, pp, its, tl, lambda0=lm.LAMBDA0):
        used.append((len(q), lambda0))
        return lm._iterate(_two_branch_closure, q, pp, its, tl, lambda0)

    start = np.where(np.arange(5) == 2, np.nan, np.sqrt(x) * 1.05)[:, None, None]  # pose 2: no guess
    q = lm.solve(_two_branch_closure, np.ones((1, 1)), p, 5, iterate=iterate, start=start)
    assert used == [(5, lm.GUESS_LAMBDA0), (1, lm.LAMBDA0)]
    np.testing.assert_allclose(q[:, 0, 0], np.sqrt(x), rtol=0, atol=1e-14)
    counts = {}
    for lam in (lm.LAMBDA0, lm.GUESS_LAMBDA0):
        calls = []

        def counted(qq, pp):
            calls.append(1)
            return _two_branch_closure(qq, pp)

        lm._iterate(counted, np.sqrt(x)[:, None, None] * 1.01, p, lm.MAX_ITERATIONS, lm.TOL, lam)
        counts[lam] = len(calls)
    assert counts[lm.GUESS_LAMBDA0] < counts[lm.LAMBDA0]
    calls = []

    def counted(qq, pp):
        calls.append(1)
        return _two_branch_closure(qq, pp)

    lm.solve(counted, np.ones((1, 1)), p, 5, start=np.sqrt(x)[:, None, None] * 1.01)  # its own iterations
    assert len(calls) == counts[lm.GUESS_LAMBDA0]


def test_a_guess_from_the_default_geometry_finds_what_the_reference_finds(numeric):
    """The predictor is built at the default parameters; with a geometry changed by 10 %
    (the platform radius) Newton from its guesses reaches the same poses and the same
    configurations as from the reference alone."""
    from eigentwist.runtime.completion import padded_references
    from eigentwist.runtime.levenberg_marquardt import solve

    ev, shipped = numeric["hexapod"]
    completion = ev.completion
    reference = np.array(padded_references(ev.robot.legs), dtype=float)
    poses = random_poses(shipped.robot, 40, seed=4)
    for factor in (0.9, 1.1):
        params = {"R_p": ev.defaults["R_p"] * factor}
        x = completion.poses(poses, params)
        kp = completion.closure_inputs(x, completion.resolver.resolve(len(x), params, "none"))
        signs = completion.assembly()["sign"]

        def branch(q):
            return completion.levers(q, kp)

        plain = solve(ev.kernels.loop_closure, reference, kp, len(x), branch=branch, signs=signs)
        guessed = solve(
            ev.kernels.loop_closure,
            reference,
            kp,
            len(x),
            branch=branch,
            signs=signs,
            start=completion.predictor()(x),
        )
        assert np.array_equal(np.isnan(plain), np.isnan(guessed)) and np.isfinite(plain).any()
        assert np.nanmax(np.abs(plain - guessed)) < 1e-10


def test_the_evaluator_starts_newton_from_its_predictor(numeric, monkeypatch):
    """``solve_joints`` hands Newton the predictor's guesses of its poses (the same solution
    as from the reference, fewer iterations)."""
    import copy

    from eigentwist.runtime import levenberg_marquardt as lm

    ev = copy.copy(numeric["hexapod"][0])
    ev.completion = copy.copy(ev.completion)
    ev.completion.__dict__.pop("_newton_memo", None)
    seen = []
    solve = lm.solve

    def spy(*args, **kwargs):
        seen.append(kwargs.get("start"))
        return solve(*args, **kwargs)

    monkeypatch.setattr(lm, "solve", spy)
    poses = random_poses(numeric["hexapod"][1].robot, 7, seed=9)
    x = ev.completion.poses(poses, {})
    ev.joint_angles(poses)
    assert len(seen) == 1 and np.array_equal(seen[0], ev.completion.predictor()(x))


def test_the_tangent_solves_consistent_closures_and_leaves_unread_coordinates():
    """dq/ds = -A^+ dr/ds: exact for a consistent system with more rows than coordinates,
    and 0 for a coordinate no row reads (a padded leg's column of zeros)."""
    from eigentwist.runtime.levenberg_marquardt import tangent

    rng = np.random.default_rng(5)
    A = rng.normal(size=(4, 6, 3))
    dq = rng.normal(size=(4, 3, 2))
    np.testing.assert_allclose(tangent(A, -A @ dq), dq, rtol=0, atol=1e-12)
    padded = np.concatenate([A, np.zeros((4, 6, 1))], axis=-1)
    got = tangent(padded, -A @ dq)
    np.testing.assert_allclose(got[:, :3], dq, rtol=0, atol=1e-12)
    assert np.array_equal(got[:, 3], np.zeros((4, 2)))


def test_the_predicted_start_is_the_tangent_of_the_solution_and_none_where_singular():
    """q = sqrt(x) closes r = q^2 - x: at (q, x) = (1, 1) dq/dx = 1/2, so the guess at x is
    1 + (x - 1)/2; where the closure's Jacobian is not finite there is no guess."""
    from eigentwist.runtime.levenberg_marquardt import predicted_start

    def inputs_at(x):
        return {"x": x[:, 0]}

    guess = predicted_start(_two_branch_closure, np.ones((1, 1)), inputs_at, np.array([1.0]))
    x = np.array([[1.0], [1.2], [0.7]])
    np.testing.assert_allclose(guess(x)[:, 0, 0], 1 + (x[:, 0] - 1) / 2, rtol=1e-9)
    assert guess(x).shape == (3, 1, 1)

    def broken(q, p):
        out = _two_branch_closure(q, p)
        return {**out, "dresidual": out["dresidual"] * np.nan}

    assert predicted_start(broken, np.ones((1, 1)), inputs_at, np.array([1.0])) is None


def test_the_first_guess_is_the_implicit_derivative_of_the_ik(numeric):
    """The predictor is q_ref at x_ref exactly and moves along dq/dx = -A^+ dr/dx: its error
    against the solved IK falls as the square of the step from x_ref (first order exact),
    along any direction of the workspace."""
    ev, _ = numeric["hexapod"]
    guess = ev.completion.predictor()
    x_ref = np.asarray(ev.robot.x_ref, dtype=float)
    assert np.array_equal(guess(x_ref[None])[0], ev.assembly()["q"])
    direction = np.random.default_rng(3).standard_normal(len(x_ref))
    direction /= np.linalg.norm(direction)
    errors = []
    for h in (2e-3, 1e-3):
        x = (x_ref + h * direction)[None]
        errors.append(np.abs(guess(x) - ev.joint_angles(x)).max())
    assert errors[1] > 0
    assert 3.0 < errors[0] / errors[1] < 5.0  # second order: 4 for half the step


# ---------------------------------------------------------------- the assembly branch at x_ref
def _hexapod_legs_at_home():
    """The shipped hexapod's legs at x_ref (the platform 0.8 m above the base, level), from
    its geometry: each base point b_i, its strut vector d_i = p + a_i - b_i, and the U joint's
    angles of d_i (joint frame: x up, y along the base circle's tangent, z = x cross y; the
    strut e_x turned about y by q1, then about z by q2: (cos q1 cos q2, sin q2, -sin q1 cos q2))."""
    from eigentwist.robots import hexapod

    tb, ta = (np.radians(hexapod.BASE_ANGLES), np.radians(hexapod.PLATFORM_ANGLES))
    b = 0.50 * np.stack([np.cos(tb), np.sin(tb), 0 * tb], -1)
    d = np.array([0.0, 0.0, 0.80]) + 0.30 * np.stack([np.cos(ta), np.sin(ta), 0 * ta], -1) - b
    up, tangent = np.broadcast_to([0.0, 0.0, 1.0], b.shape), np.stack([-np.sin(tb), np.cos(tb), 0 * tb], -1)
    frame = np.stack([up, tangent, np.cross(up, tangent)], -1)  # columns x, y, z
    f = np.einsum("kji,kj->ki", frame, d)
    length = np.linalg.norm(d, axis=-1)
    q = np.stack([np.arctan2(-f[:, 2], f[:, 0]), np.arcsin(f[:, 1] / length), length], -1)
    return b, d, q


def _where(residual: float) -> str:
    return (
        "hexapod_urdf: leg 1's reference (0, 0, 0.8) (rad; m for P) does not close its loop at "
        f"x_ref [0.0, 0.0, 0.8, 0.0, 0.0, 0.0]: residual {residual:.3g} (m, rad)"
    )


def test_assembly_is_the_geometry_and_each_refusal_names_the_leg(numeric, monkeypatch):
    """The assembly record at x_ref: the strut standing 0.8 m up misses the platform point by
    |b_i - a_i| in the base plane (the residual), the configuration the homotopy reaches is
    the U angles and the strut length of the geometry. A path that meets a singularity, a
    Newton solution that does not converge or lands on another branch (a strut 2 pi longer:
    a length is not an angle) is refused word for word; an angle 2 pi away is the same branch."""
    from eigentwist.runtime import levenberg_marquardt as lm
    from eigentwist.runtime.errors import AssemblyError
    from eigentwist.runtime.evaluator import Evaluator

    ev, _ = numeric["hexapod"]
    _, d, q_home = _hexapod_legs_at_home()
    miss = np.linalg.norm(d[:, :2], axis=-1)  # the strut's top at b_i + 0.8 e_z, the platform's at p + a_i
    record = Evaluator(ev.robot, ev.module, "numpy").assembly()
    np.testing.assert_allclose(record["residual"], miss, rtol=1e-12)
    np.testing.assert_allclose(record["q"], q_home, rtol=0, atol=1e-9)
    where = _where(miss[0])
    e_g = ", ".join(f"{v:.6g}" for v in record["q"][0])
    real_solve, real_path = lm.solve, lm.continuation

    def path_lost(*args, **kw):
        q, t = real_path(*args, **kw)
        q = q.copy()
        q[0] = np.nan
        return q, t

    def solve_moved(shift):
        def moved(*args, **kw):
            q = real_solve(*args, **kw).copy()
            q[0, 0] += shift
            return q

        return moved

    with monkeypatch.context() as mp:
        mp.setattr(lm, "continuation", path_lost)
        with pytest.raises(AssemblyError) as err:
            Evaluator(ev.robot, ev.module, "numpy")
    assert str(err.value) == (
        f"{where}, and no path of closed configurations leads from it there (a singularity between): "
        "expected the leg's joint coordinates at x_ref"
    )
    moved_by = {
        "does not converge": np.array([np.nan, 0.0, 0.0]),
        "closes on another assembly branch ({})".format(
            ", ".join(f"{v:.4g}" for v in q_home[0] + [0.0, 0.0, 2 * np.pi])
        ): np.array([0.0, 0.0, 2 * np.pi]),
    }
    for found, shift in moved_by.items():
        with monkeypatch.context() as mp:
            mp.setattr(lm, "solve", solve_moved(shift))
            with pytest.raises(AssemblyError) as err:
                Evaluator(ev.robot, ev.module, "numpy")
        want = f"{where}; Newton's method from it {found}: expected a reference on its own branch, e.g. ({e_g})"
        assert str(err.value) == want
    with monkeypatch.context() as mp:
        mp.setattr(lm, "solve", solve_moved(np.array([2 * np.pi, -2 * np.pi, 0.0])))
        assert np.array_equal(Evaluator(ev.robot, ev.module, "numpy").assembly()["q"], record["q"])


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_pose_off_the_recorded_branch_is_named(numeric, backend, monkeypatch):
    """A leg recorded on the other branch (its determinant's sign flipped): every pose is off
    it, refused word for word (through the C pass too), and invalid in a batch."""
    from eigentwist.runtime.evaluator import Evaluator

    ev, _ = numeric["hexapod"]
    if backend == "c":
        from eigentwist.runtime import ccompile

        try:
            ccompile.find_compiler()
        except ccompile.CompilerNotFoundError as exc:
            skip_tier("compiled", str(exc))
        ev = eigentwist.load(hexapod_urdf.describe(), backend="c", threads=1, progress=lambda m: None)
    flipped = Evaluator(ev.robot, ev.module, backend, kernels=ev.kernels, threads=1)
    assert flipped.c_route.fused is (backend == "c")
    if backend == "c":  # the legs' Newton iterations run in C (by chunks): at x_ref, the geometry's joints
        iterations, chunks = [], ev.kernels.branch_solver
        monkeypatch.setattr(ev.kernels, "branch_solver", lambda *a, **kw: iterations.append(1) or chunks(*a, **kw))
        home = np.array([ev.robot.x_ref])
        q = flipped.solve_joints(home, flipped.parameter_values(1))
        np.testing.assert_allclose(q[0], _hexapod_legs_at_home()[2], rtol=0, atol=1e-9)
        assert iterations
    flipped.assembly()["sign"][1] *= -1  # as if leg 2 had been assembled the other way
    x = np.array([[0.01, -0.02, 0.78, 0.03, 0.0, -0.05], [0.0, 0.0, 0.8, 0.0, 0.0, 0.0]])
    with pytest.raises(UnreachablePoseError) as err:
        flipped.frequencies(x, "rigid")
    assert str(err.value) == (
        "pose [0.01, -0.02, 0.78, 0.03, 0.0, -0.05] (m and rad) is unreachable for leg 2 on its assembly branch: "
        "Newton's method closes the loop there only on another branch (leg determinant of sign -1; +1 at x_ref, "
        "where the description's reference puts the robot)"
    )
    assert not flipped.valid(x).any()


def test_the_pose_inputs_are_computed_once_and_left_out_of_the_memo_key(numeric, monkeypatch):
    """Newton reads the pose inputs (x, y, z, rot_*, R_ij) the caller computed from the same
    poses, or computes them once for the batch; the memo key, which holds the poses, leaves
    them out; every other input stays in it."""
    import copy

    ev, shipped = numeric["hexapod"]
    completion = copy.copy(ev.completion)
    completion.__dict__.pop("_newton_memo", None)
    poses = random_poses(shipped.robot, 9, seed=4)
    p = ev.resolver.resolve(len(poses), {}, "none")
    with_pose = completion.closure_inputs(poses, p)
    assert completion.pose_input_names() == {"x", "y", "z", "rot_x", "rot_y", "rot_z"} | {
        f"R_{i}{j}" for i in range(3) for j in range(3)
    }
    assert completion.pose_input_names() <= with_pose.keys()
    assert completion.newton_key(poses, with_pose) == completion.newton_key(poses, p)
    moved = {**p, "R_p": np.asarray(p["R_p"]) * 1.01}
    assert completion.newton_key(poses, moved) != completion.newton_key(poses, p)

    calls = []
    kernel_pose_inputs = type(completion).kernel_pose_inputs

    def count(self, x):
        calls.append(len(x))
        return kernel_pose_inputs(self, x)

    monkeypatch.setattr(type(completion), "kernel_pose_inputs", count)
    given = completion.solve_joints(poses, with_pose)
    assert calls == []  # read from the caller's inputs
    completion.__dict__.pop("_newton_memo", None)
    computed = completion.solve_joints(poses, p)
    assert calls == [len(poses)]  # once for the batch
    np.testing.assert_array_equal(given, computed)
    assert completion.solve_joints(poses, with_pose) is computed  # one memo entry for both
    # a 3-DoF robot's pose inputs are its position
    assert numeric["heli4"][0].completion.pose_input_names() == {"x", "y", "z"}


def _c_hexapod_urdf():
    """The hexapod in URDF form on the C backend (skips without a compiler)."""
    return _c_numeric("hexapod_urdf")


def _c_numeric(robot: str):
    """A numeric-IK robot on the C backend, one thread (skips without a compiler): the hexapod
    in URDF form (its legs' levers read only joint coordinates: the geometry is numbers) or
    the gallery's 6-RUS (its levers also read the parameters R_b, l_c, l_r and the pose)."""
    from eigentwist.runtime import ccompile

    try:
        ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    description = hexapod_urdf.describe() if robot == "hexapod_urdf" else ROOT / "examples" / "robots" / "rus6.py"
    return eigentwist.load(description, backend="c", threads=1, progress=lambda m: None)


@pytest.mark.parametrize("predicted", [True, False])
def test_the_first_stage_in_c_gives_the_long_ways_bits(monkeypatch, predicted):
    """Numeric IK's first stage over the batch in C (``CKernels.branch_solver``, grains on the
    threads) and, for a chunk with a pose that does not converge on its branch there, the long
    way: the joints, the off-branch flags and the frequencies equal the long way's alone bit
    for bit, past several chunks with poses beyond the workspace among them (chunks taken both
    ways), on one and two threads; from the predicted start, and from the reference with the
    reference's first damping where no start is predicted (a singular assembly configuration)."""
    from eigentwist.runtime import completion

    ev = _c_hexapod_urdf()
    if not predicted:
        monkeypatch.setitem(ev.completion.__dict__, "_predictor", None)
    monkeypatch.setattr(completion, "NEWTON_CHUNK", 256)
    poses = random_poses(ev.robot, 1500, seed=33)
    far = poses[700:1100].copy()
    far[:, :3] *= 40.0  # beyond the legs' reach: Newton does not close them
    poses[700:1100] = far
    p = ev.parameter_values(len(poses))
    taken = []
    solvers = ev.kernels.branch_solver

    def counted(*a, **kw):
        solver = solvers(*a, **kw)

        def call(*b, **kb):
            done = solver(*b, **kb)
            taken.append([bool(done[sl].all()) for sl in completion.chunks(len(done), 256)])
            return done

        return call

    monkeypatch.setattr(ev.kernels, "branch_solver", counted)
    many = eigentwist.load(hexapod_urdf.describe(), backend="c", threads=2, progress=lambda m: None)
    monkeypatch.setattr(many.kernels, "branch_solver", counted)
    if not predicted:
        monkeypatch.setitem(many.completion.__dict__, "_predictor", None)
    fast = [e.completion.solve_joints(poses, p) for e in (ev, many)]
    fast_off = ev.completion._newton_memo[next(iter(ev.completion._newton_memo))][1]
    fast_freq = ev.modes(poses, "rigid", invalid="nan").freq_hz
    assert True in taken[0] and False in taken[0]  # chunks taken from C and the long way
    monkeypatch.setattr(ev.kernels, "branch_solver", lambda *a, **kw: None)
    ev.completion.__dict__.pop("_newton_memo", None)
    slow = ev.completion.solve_joints(poses, p)
    slow_off = ev.completion._newton_memo[next(iter(ev.completion._newton_memo))][1]
    assert np.isnan(slow[750]).all() and np.isfinite(slow[:700]).all()
    assert all(q.tobytes() == slow.tobytes() for q in fast) and fast_off.tobytes() == slow_off.tobytes()
    ev.completion.__dict__.pop("_newton_memo", None)
    assert ev.modes(poses, "rigid", invalid="nan").freq_hz.tobytes() == fast_freq.tobytes()


@pytest.mark.parametrize("robot", ["hexapod_urdf", "rus6"])
def test_the_first_stage_is_done_only_where_every_leg_closes_on_its_branchs_sign(robot):
    """``BranchSolver``'s done flag on each side of its decisions: every leg converged with its
    branch's lever sign (done); one leg's branch sign flipped (not done, on every pose); a
    branch sign of 0 (either sign: done); a pose Newton does not close (not done, alone). A
    pose's result does not depend on its grain, its batch's first pose, the threads or the
    signs' number type."""
    from eigentwist.runtime.completion import take
    from eigentwist.runtime.levenberg_marquardt import LAMBDA0, MAX_ITERATIONS, TOL

    ev = _c_numeric(robot)
    comp = ev.completion
    n = 700  # several grains
    poses = random_poses(ev.robot, 2 * n, seed=34)
    poses = poses[ev.valid(poses, "none")][:n]  # reachable on the assembly branch
    assert len(poses) == n
    poses[7, :3] *= 40.0
    whole = comp.closure_inputs(poses, ev.parameter_values(n))
    signs = np.asarray(comp.assembly()["sign"], dtype=float)
    start = np.broadcast_to(comp.assembly()["q"], (n,) + np.shape(comp.assembly()["q"]))
    assert set(np.unique(signs)) <= {-1.0, 1.0}

    def done(s, rows=slice(0, n), threads=1):
        q = np.array(start[rows], order="C")
        ok = ev.kernels.branch_solver(take(whole, rows), len(q), s)(q, MAX_ITERATIONS, TOL, LAMBDA0, threads)
        return q, ok

    q, ok = done(signs)
    assert ok.sum() == n - 1 and not ok[7] and np.isfinite(q[ok]).all()
    levers = comp.levers(q, whole)
    np.testing.assert_array_equal(np.sign(levers[ok]), np.broadcast_to(signs, levers[ok].shape))
    flipped = signs.copy()
    flipped[1] *= -1
    assert not done(flipped)[1].any()
    either = signs.copy()
    either[1] = 0.0
    assert done(either)[1].sum() == n - 1
    q_part, ok_part = done(signs, slice(10, 610))  # other grains, the inputs from pose 10
    assert ok_part.all() and q_part.tobytes() == q[10:610].tobytes()
    q_two, ok_two = done(signs, threads=2)
    assert q_two.tobytes() == q.tobytes() and np.array_equal(ok_two, ok)
    q_int, ok_int = done(signs.astype(int))
    assert q_int.tobytes() == q.tobytes() and np.array_equal(ok_int, ok)
    for bad in (np.asfortranarray(q), q.astype(np.float32), np.ascontiguousarray(q[:, :, :-1])):
        with pytest.raises(InputError, match="C-contiguous float64"):
            ev.kernels.branch_solver(whole, n, signs)(bad, MAX_ITERATIONS, TOL, LAMBDA0)


def test_the_branch_solver_needs_a_closure_kernel_and_a_one_output_lever():
    """``CKernels.branch_solver`` on each side of its conditions: with the ``loop_closure``
    kernel and a ``lever`` kernel whose one output is the lever, a solver; without either, or
    with a lever kernel of other outputs, None (the caller solves the long way). The closure's
    block function is the exported one where its outputs are laid out as the driver's rows,
    else None (the driver calls the kernel)."""
    ev = _c_numeric("rus6")
    kernels, n = ev.kernels, 4
    poses = random_poses(ev.robot, 4 * n, seed=35)
    whole = ev.completion.closure_inputs(poses[ev.valid(poses, "none")][:n], ev.parameter_values(n))
    signs = np.asarray(ev.completion.assembly()["sign"], dtype=float)
    spec = dict(kernels._spec)
    assert kernels.branch_solver(whole, n, signs) is not None
    lever = spec["lever"]
    for changed in (
        {k: v for k, v in spec.items() if k != "loop_closure"},
        {k: v for k, v in spec.items() if k != "lever"},
        {**spec, "lever": {**lever, "outputs": [*lever["outputs"], ["other", [1]]]}},
    ):
        kernels._spec = changed
        try:
            assert kernels.branch_solver(whole, n, signs) is None
        finally:
            kernels._spec = spec
    closure = spec["loop_closure"]
    legs, nq = kernels.N_LEGS, kernels.JOINTS_PER_LEG
    block = kernels._closure_tables(whole, n, legs, nq, [])[-1]
    assert block == ctypes.cast(getattr(kernels._lib, closure["block"]), ctypes.c_void_p).value
    assert kernels._block(closure, False) is None
    assert kernels._block({k: v for k, v in closure.items() if k != "block"}, True) is None


def test_a_failing_batch_driver_raises_with_its_code(monkeypatch):
    """The first return code a grain of the batch driver leaves (a kernel that could not
    allocate: -2) reaches the caller as a RuntimeError naming it."""
    from eigentwist.runtime import c_levenberg_marquardt as lm
    from eigentwist.runtime.levenberg_marquardt import LAMBDA0, MAX_ITERATIONS, TOL

    ev = _c_numeric("hexapod_urdf")
    whole = ev.completion.closure_inputs(np.array([ev.robot.x_ref]), ev.parameter_values(1))
    solver = ev.kernels.branch_solver(whole, 1, ev.completion.assembly()["sign"])

    def failing(state):
        ctypes.cast(state, ctypes.POINTER(lm._BranchBatch)).contents.rc = -2
        return -2

    monkeypatch.setattr(lm, "branch_driver", lambda: failing)
    q = np.array(ev.completion.assembly()["q"], dtype=float)[None].copy()
    with pytest.raises(RuntimeError, match="returned -2"):
        solver(q, MAX_ITERATIONS, TOL, LAMBDA0)


@pytest.mark.parametrize("robot", ["hexapod_urdf", "rus6"])
def test_the_starts_predicted_in_c_are_the_predictors_bits(robot):
    """``BranchSolver(..., predict=(poses, prediction))`` predicts each grain's starts in C
    (:class:`~eigentwist.runtime.levenberg_marquardt.Prediction`'s products rounded and summed
    in order): the same joints and done flags, bit for bit, as the predictor's starts computed
    in NumPy and handed over; poses of another shape are refused, naming both shapes."""
    from eigentwist.runtime.levenberg_marquardt import GUESS_LAMBDA0, MAX_ITERATIONS, TOL

    ev = _c_numeric(robot)
    comp = ev.completion
    n = 300
    poses = random_poses(ev.robot, n, seed=35)
    x = comp.poses(poses, {})
    whole = comp.closure_inputs(x, ev.parameter_values(n))
    signs = comp.assembly()["sign"]
    guess = comp.predictor()
    given = np.ascontiguousarray(guess(x))
    ok_given = ev.kernels.branch_solver(whole, n, signs)(given, MAX_ITERATIONS, TOL, GUESS_LAMBDA0)
    q = np.empty_like(given)
    ok = ev.kernels.branch_solver(whole, n, signs)(q, MAX_ITERATIONS, TOL, GUESS_LAMBDA0, predict=(x, guess))
    assert ok.any() and np.array_equal(ok, ok_given) and q.tobytes() == given.tobytes()
    solver = ev.kernels.branch_solver(whole, n, signs)
    with pytest.raises(InputError, match=rf"poses: expected \({n}, {x.shape[1]}\).*got \({n - 1}, {x.shape[1]}\)"):
        solver(q, MAX_ITERATIONS, TOL, GUESS_LAMBDA0, predict=(x[1:], guess))
