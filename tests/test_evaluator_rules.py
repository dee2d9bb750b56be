"""The evaluator's rules on the shipped robots' NumPy modules: every refusal names the bad
value, every threshold and fallback is tested on both sides, and every result is checked
against an independent computation (a generalized eigenproblem solved here with SciPy, the
blocks of the matrices, Rodrigues' formula, symmetry)."""

from __future__ import annotations

import types

import numpy as np
import pytest
import scipy.linalg

import eigentwist
from eigentwist.runtime import InputError, SingularPoseError, UnreachablePoseError, UnstablePoseError
from eigentwist.runtime import condense
from eigentwist.runtime.completion import CHUNK, chunks, masked, take, user_rows
from eigentwist.runtime.evaluator import AXES, Evaluator, Modes


@pytest.fixture(scope="module")
def heli4():
    return eigentwist.load("heli4", backend="numpy")


@pytest.fixture(scope="module")
def hexapod():
    return eigentwist.load("hexapod", backend="numpy")


@pytest.fixture(scope="module")
def delta():
    return eigentwist.load("delta", backend="numpy")


def fresh(name="heli4") -> Evaluator:
    """A new evaluator (nothing remembered yet)."""
    return eigentwist.load(name, backend="numpy")


#: two reachable Heli4 poses off the symmetry axis (m)
POSES = np.array([[0.02, -0.03, -0.62], [-0.05, 0.04, -0.6]])


def hz(K, M):
    """Natural frequencies of K v = omega^2 M v, ascending (Hz): SciPy, independent of the
    evaluator's solver."""
    return np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)) / (2 * np.pi)


# ----------------------------------------------------------------- poses
def test_one_pose_is_a_row_and_a_batch_its_rows(heli4):
    one = heli4.frequencies(POSES[0])
    both = heli4.frequencies(POSES)
    assert one.shape == (1, 6) and both.shape == (2, 6)
    np.testing.assert_allclose(both[0], one[0], rtol=1e-12)


@pytest.mark.parametrize(
    "poses, shape",
    [(np.zeros((2, 2)), r"\(2, 2\)"), (np.zeros((1, 2, 3)), r"\(1, 2, 3\)"), (np.zeros(4), r"\(4,\)")],
)
def test_poses_of_the_wrong_shape_name_it_and_the_columns(heli4, poses, shape):
    with pytest.raises(
        InputError, match=rf"poses has shape {shape}: expected \(N, 3\) poses of heli4, columns x, y, z \(m\)$"
    ):
        heli4.frequencies(poses)


def test_a_six_dof_robots_poses_name_metres_and_radians(hexapod):
    with pytest.raises(
        InputError, match=r"expected \(N, 6\) poses of hexapod, columns x, y, z, rot_x, rot_y, rot_z \(m and rad\)"
    ):
        hexapod.frequencies(np.zeros((1, 3)))
    with pytest.raises(
        InputError, match=r"pose 0 = \[0.0, 0.0, nan, 0.0, 0.0, 0.0\] is not finite: expected numbers \(m and rad\)"
    ):
        hexapod.frequencies([0.0, 0.0, np.nan, 0.0, 0.0, 0.0])


def test_no_pose_is_refused(heli4):
    with pytest.raises(InputError, match=r"^poses is empty: expected at least one \(x, y, z\) pose \(m\)$"):
        heli4.frequencies(np.zeros((0, 3)))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_the_first_non_finite_pose_is_named(heli4, bad):
    poses = np.array([POSES[0], POSES[1], [0.0, bad, -0.6], [bad, 0.0, -0.6]])
    with pytest.raises(InputError, match=rf"^pose 2 = \[0.0, {bad!r}, -0.6\] is not finite: expected numbers \(m\)$"):
        heli4.frequencies(poses)


def test_a_six_dof_robots_kernels_read_the_pose_and_its_rotation_matrix(hexapod, heli4):
    pose = np.array([[0.01, -0.02, 0.8, 0.1, -0.2, 0.3], [0.0, 0.0, 0.75, 0.0, 0.0, 0.0]])
    got = hexapod.kernel_pose_inputs(pose)
    assert set(got) == {"x", "y", "z", "rot_x", "rot_y", "rot_z"} | {f"R_{i}{j}" for i in range(3) for j in range(3)}
    for k, name in enumerate(("x", "y", "z", "rot_x", "rot_y", "rot_z")):
        np.testing.assert_array_equal(got[name], pose[:, k])
    for row in range(2):  # Rodrigues: exp of the rotation vector's skew matrix
        w = pose[row, 3:]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        R = scipy.linalg.expm(W)
        for i in range(3):
            for j in range(3):
                assert got[f"R_{i}{j}"][row] == pytest.approx(R[i, j], abs=1e-14)
    assert hexapod.pose_inputs(pose).keys() == got.keys()
    assert heli4.kernel_pose_inputs(POSES) == {}
    xyz = heli4.pose_inputs(POSES)
    assert list(xyz) == ["x", "y", "z"] and all((xyz[c] == POSES[:, k]).all() for k, c in enumerate("xyz"))
    assert heli4.closure_inputs(POSES, {"k_a": 1.0})["k_a"] == 1.0
    assert (heli4.closure_inputs(POSES, {"k_a": 1.0})["z"] == POSES[:, 2]).all()


def test_the_modes_axes_are_the_allowed_twists_of_the_rigid_model(heli4, hexapod):
    assert heli4.axes("rigid") == ("x", "y", "z") and heli4.axes("flexible") == AXES
    assert hexapod.axes("rigid") == AXES and hexapod.rigid_size() == 6 and heli4.rigid_size() == 3
    assert heli4.modes(POSES, "rigid").axes == ("x", "y", "z")
    assert repr(heli4) == "<eigentwist evaluator 'heli4' backend='numpy'>"
    assert heli4.spec == "heli4" and heli4.dof == 3 and hexapod.dof == 6


# ------------------------------------------------------------ parameters
def test_a_leg_level_parameter_takes_one_value_per_leg(heli4):
    assert heli4.accepts("k_a") and heli4.accepts("eta_a@1") and heli4.accepts("eta_a@4")
    for name in ("eta_a@0", "eta_a@5", "eta_a@x", "k_a@1", "nope", "nope@1", "eta_a@"):
        assert not heli4.accepts(name), name
    p = heli4.parameter("eta_a@3")
    assert p.name == "eta_a@3" and p.unit == heli4.parameter("eta_a").unit
    assert heli4.parameter("k_a") is heli4.parameters["k_a"]
    with pytest.raises(
        InputError, match=r"^parameter 'eta_a@5': '5' is not a leg number; expected eta_a@N with N in 1..4"
    ):
        heli4.parameter("eta_a@5")
    with pytest.raises(
        InputError,
        match=r"^parameter 'k_a@2': k_a belongs to no leg-level effect, so it has no per-leg value "
        r"\(leg-level parameters: eta_a, E_rod",
    ):
        heli4.parameter("k_a@2")


def test_an_unknown_parameter_is_named_with_a_suggestion(heli4):
    with pytest.raises(
        InputError,
        match=r"^unknown parameter\(s\) 'k_A', 'zz@2' for heli4.*did you mean.*k_a.*expected names from R, l1, "
        r".* \(NAME@N for one leg\)$",
    ):
        heli4.frequencies(POSES, k_A=1.0, **{"zz@2": 1.0})


def test_a_leg_level_parameter_of_a_robot_without_one_is_refused(hexapod):
    assert hexapod.accepts("k_s@6") and not hexapod.accepts("k_s@7")


@pytest.mark.parametrize("shape", [(3,), (1, 2), (2, 1)])
def test_a_parameter_is_a_scalar_or_one_value_per_pose(heli4, shape):
    with pytest.raises(
        InputError,
        match=rf"^parameter 'k_a' has shape \({shape[0]}, ?{shape[1] if len(shape) > 1 else ''}\): "
        r"expected a scalar or \(2,\) for 2 poses$",
    ):
        heli4.frequencies(POSES, k_a=np.full(shape, 2000.0))


def test_one_value_per_pose_or_one_for_all(heli4):
    each = heli4.frequencies(POSES, "rigid", k_a=np.array([1000.0, 4000.0]))
    one = heli4.frequencies(POSES, "rigid", k_a=np.array([1000.0]))
    # rigid model: every stiffness is the actuators' (no structural compliance), f ~ sqrt(k_a)
    np.testing.assert_allclose(one[1] * 2, each[1], rtol=1e-10)
    np.testing.assert_allclose(one[0], each[0], rtol=1e-12)
    np.testing.assert_allclose(heli4.frequencies(POSES, "rigid", k_a=1000.0), one, rtol=1e-12)


def test_a_legs_own_value_out_of_bounds_is_named_with_its_leg(heli4):
    with pytest.raises(InputError, match=r"^parameter 'eta_a@2' = 1.5 -: expected a finite value in \(0, 1\]$"):
        heli4.frequencies(POSES, **{"eta_a@2": 1.5})
    with pytest.raises(InputError, match=r"^parameter 'eta_a' = 1.5 -"):
        heli4.frequencies(POSES, eta_a=1.5)


def test_a_legs_own_values_meet_their_effects_constraints(heli4):
    model = "paper,lower_link_compliance"
    with pytest.raises(
        InputError, match=r"^leg 2: parameters r_i_l1 = 0.02 m, r_o_l1 = 0.012 m: .* expected r_i_l1 < r_o_l1$"
    ):
        heli4.frequencies(POSES, model, **{"r_i_l1@2": 0.02})
    with pytest.raises(InputError, match=r"^leg 3: parameters r_i_l1 = 0.011 m, r_o_l1 = 0.0105 m"):
        heli4.frequencies(POSES, model, **{"r_i_l1@3": 0.011, "r_o_l1@3": 0.0105})
    # the effect on leg 2 only: leg 2's values are checked, another leg's are not read
    with pytest.raises(InputError, match="^leg 2: "):
        heli4.frequencies(POSES, "paper,lower_link_compliance@2", **{"r_i_l1@2": 0.02})
    assert np.isfinite(heli4.frequencies(POSES, "paper,lower_link_compliance@3", **{"r_i_l1@2": 0.02})).all()
    assert np.isfinite(heli4.frequencies(POSES, model, **{"r_i_l1@2": 0.0119})).all()  # just inside
    # without the effect the constraint does not apply
    assert np.isfinite(heli4.frequencies(POSES, "paper", **{"r_i_l1@2": 0.02})).all()


def test_a_shared_constraint_is_checked_on_the_shared_values(heli4):
    with pytest.raises(InputError, match=r"^parameters r_i = 0.005 m, r_o = 0.005 m"):
        heli4.frequencies(POSES, r_i=0.005)
    assert np.isfinite(heli4.frequencies(POSES, r_i=0.00499)).all()


def test_resolved_scalars_are_read_only_copies_and_arrays_are_the_callers():
    ev = fresh()
    a = ev.parameter_values(2, "rigid", k_a=1500.0)
    b = ev.parameter_values(2, "rigid", k_a=1500.0)
    assert a["k_a"] == 1500.0 and a["k_a"] is not b["k_a"]
    a["k_a"][...] = 1.0  # the caller's copy: the remembered value stays
    assert ev.parameter_values(2, "rigid", k_a=1500.0)["k_a"] == 1500.0
    p = ev.resolver.resolve(2, {"k_a": 1500.0}, "rigid")
    assert not p["k_a"].flags.writeable and p["k_a"].ndim == 0
    assert ev.resolver.resolve(2, {"k_a": 1500.0}, "rigid")["k_a"] is p["k_a"]  # the same remembered array
    assert ev.resolver.resolve(2, {"k_a": np.float32(1500.0)}, "rigid")["k_a"] is p["k_a"]
    assert ev.resolver.resolve(2, {"k_a": np.array(1500.0)}, "rigid")["k_a"] is p["k_a"]
    k = np.array([1500.0, 1600.0])
    arr = ev.resolver.resolve(2, {"k_a": k}, "rigid")["k_a"]
    np.testing.assert_array_equal(arr, k)
    assert ev.resolver.key({"k_a": k}, "rigid") is None
    assert ev.resolver.key({"k_a": "1500"}, "rigid") is None
    assert ev.resolver.key({"k_a": np.array(["a"])[0]}, "rigid") is None
    assert ev.resolver.key({"k_a": 2}, "rigid") == ("rigid", (("k_a", 2.0),))
    assert ev.resolver.key({"c_rigid": condense.EXACT}, "rigid") == ("rigid", (("c_rigid", "exact"),))
    assert ev.resolver.key({"b": 1.0, "a": 2.0}, ["actuator_loss"]) == (("actuator_loss",), (("a", 2.0), ("b", 1.0)))


def test_the_remembered_values_are_bounded():
    ev = fresh()
    first = ev.resolver.resolve(1, {"k_a": 1000.0}, "rigid")["k_a"]
    for j in range(63):
        ev.resolver.resolve(1, {"k_a": 1001.0 + j}, "rigid")
    assert len(ev.resolver._memo) == 64
    assert ev.resolver.resolve(1, {"k_a": 1000.0}, "rigid")["k_a"] is first  # still held at 64
    ev.resolver.resolve(1, {"k_a": 999.0}, "rigid")  # the 65th: the memo starts over
    assert len(ev.resolver._memo) == 1
    assert ev.resolver.resolve(1, {"k_a": 1000.0}, "rigid")["k_a"] is not first


def test_a_default_is_one_read_only_array_until_it_changes():
    ev = fresh()
    a = ev.resolver.default("k_a", 2000.0, 1, False)
    assert a == 2000.0 and not a.flags.writeable and ev.resolver.default("k_a", 2000.0, 1, False) is a
    b = ev.resolver.default("k_a", 2500.0, 1, False)
    assert b == 2500.0 and b is not a
    with pytest.raises(InputError, match=r"^parameter 'k_a' = -1.0"):
        ev.resolver.default("k_a", -1.0, 1, True)
    arr = ev.resolver.default("k_a", np.array([1.0, 2.0]), 2, False)  # an array default: as given
    np.testing.assert_array_equal(arr, [1.0, 2.0])


def test_a_default_out_of_bounds_is_refused_where_its_effect_is_on():
    ev = fresh()
    param = ev.parameters["eta_a"]
    ev.resolver.parameters = {**ev.parameters, "eta_a": param.with_values(default=1.5)}
    assert np.isfinite(ev.frequencies(POSES, "none")).all()  # actuator_loss off: eta_a unread
    with pytest.raises(InputError, match=r"^parameter 'eta_a' = 1.5"):
        ev.frequencies(POSES, "actuator_loss")
    assert "eta_a" not in ev.resolver._checked_defaults and "k_a" in ev.resolver._checked_defaults
    assert np.isfinite(ev.frequencies(POSES, "actuator_loss", eta_a=0.5)).all()


def test_the_inputs_are_floats_and_per_pose_arrays(heli4):
    p = heli4.inputs("none", {"k_a": 1500.0}, eta_a=0.7)
    assert type(p["k_a"]) is float and p["k_a"] == 1500.0 and p["eta_a"] == 0.7
    assert p["on_actuator_loss__1"] == 0.0 and p["on_rod_compliance__2"] == 0.0 and p["eta_a__3"] == 0.7
    q = heli4.inputs("paper,actuator_loss@2", **{"k_a": np.array([1.0, 2.0, 3.0]), "eta_a@2": 0.5})
    assert isinstance(q["k_a"], np.ndarray) and q["k_a"].tolist() == [1.0, 2.0, 3.0]
    assert [q[f"on_actuator_loss__{k}"] for k in range(1, 5)] == [1.0, 1.0, 1.0, 1.0]
    assert [q[f"eta_a__{k}"] for k in range(1, 5)] == [0.82, 0.5, 0.82, 0.82]
    r = heli4.inputs("actuator_loss@2")
    assert [r[f"on_actuator_loss__{k}"] for k in range(1, 5)] == [0.0, 1.0, 0.0, 0.0]
    assert r["on_payload_mass"] == 0.0 and heli4.inputs("paper,payload_mass")["on_payload_mass"] == 1.0
    # the batch is the longest array given
    with pytest.raises(
        InputError, match=r"^parameter 'k_a' has shape \(2,\): expected a scalar or \(3,\) for 3 poses$"
    ):
        heli4.inputs(k_a=np.ones(2), m_e=np.ones(3))


# ------------------------------------------------------------------ batches
def test_a_batch_is_cut_into_chunks_that_cover_it_once(heli4):
    assert list(chunks(10, 4)) == [slice(0, 4), slice(4, 8), slice(8, 10)]
    assert list(chunks(8, 4)) == [slice(0, 4), slice(4, 8)]
    assert list(chunks(3)) == [slice(0, 3)]
    assert list(chunks(CHUNK + 1)) == [slice(0, CHUNK), slice(CHUNK, CHUNK + 1)]


def test_rows_of_the_inputs_are_taken_where_an_input_has_one_per_pose():
    n = 3
    p = {"a": np.arange(3.0), "s": np.array(2.0), "one": np.array([5.0])}
    t = take(p, slice(1, 3))
    assert t["a"].tolist() == [1.0, 2.0] and t["s"] == 2.0 and t["one"].tolist() == [5.0]
    mask = np.array([True, False, True])
    m = masked(p, mask, n)
    assert m["a"].tolist() == [0.0, 2.0] and m["one"].tolist() == [5.0] and m["s"] == 2.0
    single = {"a": np.array([7.0])}
    assert masked(single, np.array([True]), 1)["a"] is single["a"]
    r = user_rows({"a": [1.0, 2.0, 3.0], "s": 4.0, "two": np.ones(2)}, mask, n)
    assert r["a"].tolist() == [1.0, 3.0] and r["s"] == 4.0 and r["two"].tolist() == [1.0, 1.0]
    assert user_rows({"a": [1.0]}, slice(0, 1), 1)["a"] == [1.0]


def test_a_batch_longer_than_a_chunk_gives_each_poses_own_result(heli4):
    n = CHUNK + 2
    poses = np.tile(POSES[0], (n, 1))
    poses[-1] = POSES[1]
    k_a = np.full(n, 2000.0)
    k_a[-2] = 8000.0  # the second chunk's first pose: its own value
    f = heli4.frequencies(poses, "rigid", k_a=k_a)
    ref = heli4.frequencies(POSES, "rigid")
    np.testing.assert_allclose(f[0], ref[0], rtol=1e-12)
    np.testing.assert_allclose(f[-1], ref[1], rtol=1e-12)
    np.testing.assert_allclose(f[-2], 2 * ref[0], rtol=1e-10)  # f ~ sqrt(k_a)
    q = heli4.joint_angles(poses[CHUNK - 1 :])
    np.testing.assert_allclose(q[-1], heli4.joint_angles(POSES[1])[0], rtol=1e-12)


# ------------------------------------------------------------ validity
def singular_z(ev) -> float:
    """z on the Heli4's axis where legs 1 and 2's lower links align with their parallelograms."""
    l1, l2, R, r, d = (ev.defaults[k] for k in ("l1", "l2", "R", "r", "d"))
    return -np.sqrt((l1 + l2) ** 2 - (R - r) ** 2) - d + 1e-9


def test_each_pose_is_valid_or_not_with_its_reason(heli4):
    P = np.array([POSES[0], [0.0, 0.0, singular_z(heli4)], [0.0, 0.0, -1.2], POSES[1]])
    assert heli4.valid(P).tolist() == [True, False, False, True]
    st = heli4.pose_status(P)
    assert st["status"].tolist() == ["reachable", "serial singular", "unreachable", "reachable"]
    assert st["code"].tolist() == [0, 2, 1, 0] and st["code"].dtype == np.int8
    assert np.isnan(st["conditioning"][2]) and np.isnan(st["lever"][2])
    # the lever relative to l1 (the robot's LEVER_SCALE): the smallest of the legs'
    lever = heli4.jacobians(P[[0, 3]])["lever"]
    np.testing.assert_allclose(st["lever"][[0, 3]], np.abs(lever).min(axis=1) / heli4.defaults["l1"], rtol=1e-12)
    assert 0 < st["conditioning"][0] <= 1 and st["lever"][1] < 1e-3
    m = heli4.modes(P, invalid="nan")
    assert m.valid.tolist() == [True, False, False, True] and m.stable.all()
    assert np.isnan(m.freq_hz[1:3]).all() and np.isnan(m.eigentwists[1:3]).all()
    np.testing.assert_allclose(m.freq_hz[[0, 3]], heli4.frequencies(POSES), rtol=1e-12)
    with pytest.raises(SingularPoseError, match="leg 1"):
        heli4.modes(P[:2])
    with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, -1.2\]"):  # before the singular one
        heli4.modes(P)
    with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, -1.2\]"):
        heli4.modes(P[2:])
    assert heli4.modes(P[:1]).valid is None


def test_an_all_valid_batch_gives_the_rows_a_mixed_batch_gives(heli4):
    # invalid="nan" with every pose valid takes the rows as they are; with one unreachable
    # pose among them, the others are solved apart and copied into NaN-filled arrays
    P = np.array([POSES[0], POSES[1]])
    whole = heli4.modes(P, invalid="nan")
    mixed = heli4.modes(np.array([POSES[0], [0.0, 0.0, -1.2], POSES[1]]), invalid="nan")
    assert whole.valid.dtype == bool and whole.valid.tolist() == [True, True] and whole.stable.all()
    assert mixed.valid.tolist() == [True, False, True]
    assert np.array_equal(whole.freq_hz, mixed.freq_hz[[0, 2]])
    assert np.array_equal(whole.eigentwists, mixed.eigentwists[[0, 2]])
    assert whole.stiffness_model == mixed.stiffness_model and tuple(whole.axes) == tuple(mixed.axes)


def test_no_valid_pose_gives_nan_and_no_error(heli4):
    m = heli4.modes([[0.0, 0.0, -1.2], [0.0, 0.0, -1.3]], invalid="nan", vectors=False)
    assert m.valid.tolist() == [False, False] and np.isnan(m.freq_hz).all() and m.eigentwists is None
    st = heli4.pose_status([[0.0, 0.0, -1.2]])
    assert st["status"].tolist() == ["unreachable"] and np.isnan(st["conditioning"]).all()
    r = heli4.modes([[0.0, 0.0, -1.2], POSES[0]], "rigid", invalid="nan")
    assert r.freq_hz.shape == (2, 3) and r.eigentwists.shape == (2, 3, 3)


# ------------------------------------------------------------- matrices
def test_matrices_are_written_into_the_callers_arrays(heli4):
    ref = heli4.matrices(POSES)
    out = {"K_F": np.zeros((2, 6, 6)), "M": np.zeros((2, 6, 6))}
    got = heli4.matrices(POSES, out=out)
    assert got["K_F"] is out["K_F"] and got["M"] is out["M"] and got["K_R"] is not None
    for k in ("M", "K_R", "K_F"):
        np.testing.assert_array_equal(got[k], ref[k])
        np.testing.assert_allclose(ref[k], np.swapaxes(ref[k], 1, 2), atol=1e-9 * np.abs(ref[k]).max())  # symmetric
    q = heli4.joint_angles(POSES)
    buf = np.zeros((2, 6, 6))
    by_joints = heli4.matrices(None, joints=q, out={"M": buf})
    assert by_joints["M"] is buf
    np.testing.assert_allclose(buf, ref["M"], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "arr, shown",
    [
        (np.zeros((3, 6, 6)), r"\(3, 6, 6\) float64"),
        (np.zeros((2, 6, 6), dtype=np.float32), r"\(2, 6, 6\) float32"),
        (np.zeros((2, 6, 6, 2))[..., 0], r"\(2, 6, 6\) float64"),  # not contiguous
        ([[0.0] * 6] * 6, "None list"),
    ],
)
def test_an_output_array_that_cannot_be_written_in_place_is_refused(heli4, arr, shown):
    with pytest.raises(
        InputError,
        match=rf"^out\['K_R'\]: expected a writeable C-contiguous float64 array of shape \(2, 6, 6\), got {shown}$",
    ):
        heli4.matrices(POSES, out={"K_R": arr})


def test_a_read_only_output_array_or_an_unknown_key_is_refused(heli4):
    ro = np.zeros((2, 6, 6))
    ro.flags.writeable = False
    with pytest.raises(InputError, match=r"^out\['M'\]: expected a writeable"):
        heli4.matrices(POSES, out={"M": ro})
    with pytest.raises(
        InputError, match=r"^out has unknown key\(s\) \['K', 'Z'\]: expected some of \['M', 'K_R', 'K_F'\]$"
    ):
        heli4.matrices(POSES, out={"Z": ro, "K": ro, "M": ro})
    with pytest.raises(InputError, match=r"^out has unknown key"):
        heli4.matrices(None, joints=heli4.joint_angles(POSES), out={"Z": ro})


def test_the_matrices_come_chunk_by_chunk(heli4):
    P = np.array([POSES[0], POSES[1], [0.0, 0.0, -0.61]])
    ref = heli4.matrices(P, k_a=np.array([1000.0, 2000.0, 3000.0]))
    parts = list(heli4.iter_matrices(P, chunk=2, k_a=np.array([1000.0, 2000.0, 3000.0])))
    assert [sl for sl, _ in parts] == [slice(0, 2), slice(2, 3)]
    for k in ("M", "K_R", "K_F"):
        np.testing.assert_array_equal(np.concatenate([m[k] for _, m in parts]), ref[k])
    assert [sl for sl, _ in heli4.iter_matrices(P, chunk=np.int64(3))] == [slice(0, 3)]
    assert [sl for sl, _ in heli4.iter_matrices(P, chunk=1)] == [slice(0, 1), slice(1, 2), slice(2, 3)]
    for bad in (0, -1, 1.5, "2"):
        with pytest.raises(
            InputError, match=rf"^chunk = {bad!r}: expected a whole number of poses >= 1$".replace(".", r"\.")
        ):
            next(heli4.iter_matrices(P, chunk=bad))
    with pytest.raises(InputError, match="k_a"):  # every input checked before the first chunk
        next(heli4.iter_matrices(P, chunk=1, k_a=np.ones(2)))


def test_the_rigid_models_pencil_is_the_translational_block(heli4, hexapod):
    mats = heli4.matrices(POSES)
    M, K = heli4.stiffness(POSES, "rigid")
    # the Heli4's allowed twists are the three translations: the (x, y, z) block of M and K_R
    np.testing.assert_allclose(M, mats["M"][:, 3:, 3:], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(K, mats["K_R"][:, 3:, 3:], rtol=1e-12)
    f = heli4.frequencies(POSES, "rigid")
    for i in range(2):
        np.testing.assert_allclose(f[i], hz(K[i], M[i]), rtol=1e-10)
    Mf, Kf = heli4.stiffness(POSES, "paper")
    np.testing.assert_array_equal(Mf, mats["M"])
    np.testing.assert_array_equal(Kf, mats["K_F"])
    B = heli4.allowed_twists(POSES)
    assert B.shape == (2, 6, 3)
    np.testing.assert_array_equal(B[0], np.eye(6)[:, 3:])
    x = np.array([hexapod.robot.x_ref, [0.01, 0.0, 0.8, 0.0, 0.05, 0.0]])
    np.testing.assert_array_equal(hexapod.allowed_twists(x), np.broadcast_to(np.eye(6), (2, 6, 6)))
    Mh, Kh = hexapod.stiffness(x, "rigid")
    np.testing.assert_allclose(Kh, hexapod.matrices(x)["K_R"], rtol=1e-12)


def test_measured_joints_give_the_poses_model(heli4, hexapod):
    q = heli4.joint_angles(POSES)
    for model in ("paper", "rigid"):
        np.testing.assert_allclose(
            heli4.frequencies(None, model, joints=q), heli4.frequencies(POSES, model), rtol=1e-12
        )
    np.testing.assert_allclose(heli4.frequencies(POSES[:1], joints=q[0]), heli4.frequencies(POSES[:1]), rtol=1e-12)
    m = heli4.modes(None, "rigid", joints=q)
    assert m.stiffness_model == "rigid" and m.axes == ("x", "y", "z")
    x = np.array([hexapod.robot.x_ref])
    qh = hexapod.joint_angles(x)
    np.testing.assert_allclose(hexapod.frequencies(x, joints=qh), hexapod.frequencies(x), rtol=1e-12)
    with pytest.raises(
        InputError,
        match=r"^joints without poses: the model of hexapod reads the pose too \(x, y, z, rot_x, rot_y, rot_z\): "
        r"give both$",
    ):
        hexapod.frequencies(None, joints=qh)


def test_measured_joints_are_checked(heli4):
    q = heli4.joint_angles(POSES)
    with pytest.raises(
        InputError,
        match=r"^joints has shape \(2, 4, 2\): expected \(N, 4, 3\) joint coordinates of heli4 \(legs x "
        r"coordinates, as joint_angles returns\)$",
    ):
        heli4.frequencies(None, joints=q[:, :, :2])
    with pytest.raises(InputError, match=r"^joints has shape \(1, 2, 4, 3\)"):
        heli4.frequencies(None, joints=q[None])
    bad = q.copy()
    bad[1, 2, 0] = np.nan
    with pytest.raises(
        InputError, match=r"^joints\[1\] is not finite: expected numbers \(rad; m for a prismatic joint\)$"
    ):
        heli4.frequencies(None, joints=bad)
    with pytest.raises(InputError, match=r"^joints has 2 rows and poses 1: expected one pose per row of joints$"):
        heli4.frequencies(POSES[:1], joints=q)
    with pytest.raises(InputError, match=r"damping effect or complex_shapes: not supported"):
        heli4.modes(None, "paper,servo_damping", joints=q)
    with pytest.raises(InputError, match=r"damping effect or complex_shapes: not supported"):
        heli4.modes(None, joints=q, complex_shapes=True)
    with pytest.raises(
        InputError,
        match=r"^joints= with a gravity preload: not supported \(the preload's derivative needs the inverse "
        r"kinematics\); drop gravity_preload from the model or give poses only$",
    ):
        heli4.modes(None, "paper,gravity_preload", joints=q)


# --------------------------------------------------------------- modes
#: a heavy payload at low actuator stiffness: gravity softens the vertical mode below zero
UNSTABLE = dict(g=50.0, k_a=50.0, m_p=100.0, p_z=0.3)


def test_an_unstable_pose_is_named_with_its_mode(heli4):
    P = np.array([POSES[0], [0.0, 0.0, -0.625]])
    m = heli4.modes(P, "rigid,gravity_preload,payload_mass", m_p=np.array([0.2, 100.0]), g=50.0, k_a=50.0, p_z=0.3)
    assert m.stable.tolist() == [True, False] and np.isnan(m.freq_hz[1, 0]) and np.isfinite(m.freq_hz[0]).all()
    assert np.isnan(m.damping_ratio[1, 0]) and (m.damping_ratio[0] == 0).all()
    with pytest.raises(
        UnstablePoseError,
        match=r"^pose \[0.0, 0.0, -0.625\] m is unstable in model actuator_loss,payload_mass,gravity_preload: "
        r"mode 1 of 3 has a negative stiffness \(omega\^2 < 0, no natural frequency\); check negative or "
        r"extreme parameters and the gravity preload$",
    ):
        heli4.modes(
            P,
            "rigid,gravity_preload,payload_mass",
            m_p=np.array([0.2, 100.0]),
            g=50.0,
            k_a=50.0,
            p_z=0.3,
            unstable="raise",
        )


def test_two_unstable_modes_are_named_together(heli4):
    freq = np.array([[1.0, 2.0, 3.0], [np.nan, 2.0, np.nan]])
    m = Modes(freq, None, ("x", "y", "z"), "rigid", stable=np.array([True, False]))
    with pytest.raises(
        UnstablePoseError,
        match=r"^pose \[0.1, 0.2, 0.3\] m is unstable in model a,b: modes 1, 3 of 3 have a negative stiffness",
    ):
        heli4.solver.raise_unstable(np.array([[9.0, 9.0, 9.0], [0.1, 0.2, 0.3]]), m, ("a", "b"))


def test_a_growing_pole_names_the_least_damped_mode(heli4):
    X = np.array([[0.0, 0.0, -0.625], [0.01, 0.0, -0.625]])
    kw = dict(k_a=np.array([2200.0, 4000.0]), t_d=1.3e-3)
    m = heli4.modes(X, "damped,servo_delay", **kw)
    assert m.stable.tolist() == [True, False]
    j = int(np.argmin(m.damping_ratio[1]))
    assert m.damping_ratio[1, j] < 0
    # the damped frequency of each pole: omega_n sqrt(1 - zeta^2)
    np.testing.assert_allclose(m.damped_hz, m.natural_hz * np.sqrt(1 - m.damping_ratio**2), rtol=1e-9)
    with pytest.raises(
        UnstablePoseError,
        match=rf"^pose \[0.01, 0.0, -0.625\] m is unstable in model actuator_loss,rod_compliance,ee_compliance,"
        rf"servo_damping,servo_delay: a pole grows \(mode {j + 1} has damping ratio {m.damping_ratio[1, j]:.3g}, or "
        r"an actuator's internal pole\); check the torque lag t_d against c_a / k_a and negative damping$",
    ):
        heli4.modes(X, "damped,servo_delay", unstable="raise", **kw)
    # no finite damping ratio: the first mode is named
    nan = types.SimpleNamespace(damping_ratio=np.full((1, 3), np.nan))
    lost = Modes(np.ones((1, 3)), None, ("x", "y", "z"), "rigid", stable=np.array([False]), damping=nan)
    with pytest.raises(UnstablePoseError, match=r"a pole grows \(mode 1 has damping ratio nan"):
        heli4.solver.raise_unstable(X[:1], lost, ("a",))


def test_the_modes_options_are_checked(heli4):
    with pytest.raises(InputError, match=r"^invalid='skip': expected 'raise' or 'nan'$"):
        heli4.modes(POSES, invalid="skip")
    with pytest.raises(InputError, match=r"^unstable='skip': expected 'raise' or 'nan'$"):
        heli4.modes(POSES, unstable="skip")
    with pytest.raises(InputError, match=r"^method='exactly': expected 'exact' or 'differences'$"):
        heli4.sensitivities(POSES, ["k_a"], method="exactly")


def test_modes_without_damping_have_no_poles(heli4):
    m = heli4.modes(POSES)
    assert (
        m.damping is None and m.complex_eigentwists is None and m.natural_hz is m.freq_hz and m.damped_hz is m.freq_hz
    )
    assert (m.damping_ratio == 0).all() and m.stable.all() and m.stable.shape == (2,)
    assert m.stiffness_model == "flexible" and m.axes == AXES
    with pytest.warns(DeprecationWarning, match=r"^Modes.kind is deprecated: use Modes.stiffness_model$"):
        assert m.kind == "flexible"
    with pytest.warns(DeprecationWarning, match=r"^Evaluator.kind is deprecated: use Evaluator.stiffness_model$"):
        assert heli4.kind("rigid") == "rigid"
    v = heli4.modes(POSES, vectors=False)
    assert v.eigentwists is None
    np.testing.assert_array_equal(v.freq_hz, m.freq_hz)
    with pytest.raises(
        InputError, match=r"^these modes were computed without eigentwists: call modes\(..., vectors=True\)$"
    ):
        v.direction
    # each eigentwist's largest entry is +1 (Eqs. 57, 65), and each solves the pencil
    M, K = heli4.stiffness(POSES)
    for i in range(2):
        V = m.eigentwists[i]
        assert np.allclose(V[np.argmax(np.abs(V), axis=0), range(6)], 1.0)
        lam = (2 * np.pi * m.freq_hz[i]) ** 2
        np.testing.assert_allclose(K[i] @ V, (M[i] @ V) * lam, rtol=1e-8, atol=1e-8 * np.abs(K[i] @ V).max())


def test_the_stiffness_model_follows_the_structural_effects(heli4):
    assert heli4.stiffness_model("rigid") == "rigid" and heli4.stiffness_model("paper") == "flexible"
    assert heli4.stiffness_model(["actuator_loss"]) == "rigid"  # an unhashable spec: computed each time
    assert heli4.stiffness_model(["actuator_loss", "rod_compliance"]) == "flexible"
    assert heli4.stiffness_model("actuator_loss,rod_compliance@2") == "flexible"
    assert heli4.damped_model("paper,servo_damping") and not heli4.damped_model("paper")


def test_the_public_methods_default_to_the_paper_model(heli4):
    paper = heli4.matrices(POSES, "paper")
    for a, b in zip(heli4.stiffness(POSES), (paper["M"], paper["K_F"])):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(heli4.frequencies(POSES), heli4.modes(POSES, "paper").freq_hz)
    assert heli4.frequencies(POSES).shape == (2, 6) and heli4.frequencies(POSES, "rigid").shape == (2, 3)
    assert heli4.parameter_values(2)["on_ee_compliance"] == 1.0
    assert heli4.parameter_values(2)["on_actuator_loss__1"] == 1.0
    assert heli4.inputs()["on_ee_compliance"] == 1.0 and heli4.inputs()["on_payload_mass"] == 0.0
    assert heli4.run_kernel("matrices", POSES)["K_F"].tolist() == paper["K_F"].tolist()
    for sl, part in heli4.iter_matrices(POSES, chunk=1):
        np.testing.assert_array_equal(part["K_F"], paper["K_F"][sl])
    rigid = heli4.iter_matrices(POSES, "rigid", chunk=1, eta_a=0.5)
    np.testing.assert_array_equal(next(rigid)[1]["K_R"], heli4.matrices(POSES[:1], "rigid", eta_a=0.5)["K_R"])
    d = heli4.sensitivities(POSES, ["k_a"], method="differences")
    np.testing.assert_allclose(d, heli4.sensitivities(POSES, ["k_a"], "paper", method="differences"), rtol=1e-12)


# ------------------------------------------------ rigid constraint directions
def test_the_paper_models_legs_have_no_rigid_direction_so_K_F_is_exact(heli4):
    params, condensed = heli4.constraint_route("paper")
    assert not condensed and params["c_rigid"] is condense.EXACT
    mats = heli4.matrices(POSES, "paper", **params)
    f = heli4.frequencies(POSES, "paper")
    for i in range(2):
        np.testing.assert_allclose(f[i], hz(mats["K_F"][i], mats["M"][i]), rtol=1e-9)
    # a compliance given other than the description's default: the user's finite constraint, K_F as is
    assert heli4.constraint_route("paper", c_rigid=1e-9) == ({"c_rigid": 1e-9}, False)
    assert heli4.constraint_route("paper", c_rigid=np.array([1e-12, 1e-9]))[1] is False
    assert heli4.constraint_route("paper", c_rigid=1e-12)[0]["c_rigid"] is condense.EXACT  # the default itself
    # the rigid model has no K_F to route
    assert heli4.constraint_route("rigid") == ({}, False)


def test_rigid_rods_are_condensed_exactly(heli4):
    model = "actuator_loss,ee_compliance"  # rods rigid: each leg keeps rigid directions
    params, condensed = heli4.constraint_route(model)
    assert condensed and params == {}
    m = heli4.modes(POSES, model)
    assert m.constrained.tolist() == [[False] * 3 + [True] * 3] * 2
    assert (m.freq_hz[:, 3:] > 1e5).all()  # the rigid constraints' stand-in (infinite) modes
    # the finite modes are the limit of the penalty model (a stated compliance c_rigid: its
    # error ~ c, its round-off ~ eps / c, both below 1e-7 at c = 1e-9)
    penalty = heli4.frequencies(POSES, model, c_rigid=1e-9)
    np.testing.assert_allclose(penalty[:, :3], m.freq_hz[:, :3], rtol=1e-7)
    assert (penalty[:, 3:] > 1e4).all()
    # the eigentwists of the finite modes solve the penalty model's pencil in the limit
    assert np.isfinite(m.eigentwists[:, :, :3]).all()
    v = heli4.modes(POSES, model, vectors=False)
    assert v.eigentwists is None
    np.testing.assert_allclose(v.freq_hz[:, :3], m.freq_hz[:, :3], rtol=1e-12)
    # invalid rows stay NaN, the valid one condensed as alone
    mixed = heli4.modes([[0.0, 0.0, -1.2], POSES[0]], model, invalid="nan")
    assert np.isnan(mixed.freq_hz[0]).all()
    np.testing.assert_allclose(mixed.freq_hz[1, :3], m.freq_hz[0, :3], rtol=1e-12)
    none = heli4.modes([[0.0, 0.0, -1.2]], model, invalid="nan")
    assert np.isnan(none.freq_hz).all()


def test_a_rigid_direction_on_one_leg_is_condensed_too(heli4):
    model = "actuator_loss,rod_compliance@2,ee_compliance"  # legs 1, 3, 4 rigid rods
    assert heli4.constraint_route(model)[1]
    m = heli4.modes(POSES[:1], model)
    stiff = heli4.frequencies(POSES[:1], model, c_rigid=1e-9)
    np.testing.assert_allclose(stiff[:, :3], m.freq_hz[:, :3], rtol=1e-7)
    assert m.constrained[0].tolist() == [False] * 3 + [True] * 3


def test_the_gravity_preload_adds_its_stiffness(heli4):
    model = "paper,payload_mass,gravity_preload"
    params, condensed = heli4.constraint_route(model, m_p=5.0)  # the rods' compliance: K_F exact
    assert not condensed and params["m_p"] == 5.0
    M, K = heli4.stiffness(POSES, model, **params)
    M0, K0 = heli4.stiffness(POSES, "paper,payload_mass", **params)
    np.testing.assert_array_equal(M, M0)
    assert not np.allclose(K, K0)
    np.testing.assert_allclose(K, np.swapaxes(K, 1, 2), atol=1e-9 * np.abs(K).max())  # still symmetric
    f = heli4.frequencies(POSES, model, m_p=5.0)
    for i in range(2):
        np.testing.assert_allclose(f[i], hz(K[i], M[i]), rtol=1e-9)
    # the preload vanishes with gravity: g -> 0 gives the model without it
    g0 = heli4.frequencies(POSES, model, m_p=5.0, g=1e-9)
    np.testing.assert_allclose(g0, heli4.frequencies(POSES, "paper,payload_mass", m_p=5.0), rtol=1e-8)
    Mr, Kr = heli4.stiffness(POSES, "rigid,payload_mass,gravity_preload", m_p=5.0)
    assert Mr.shape == (2, 3, 3) and Kr.shape == (2, 3, 3)
    fr = heli4.frequencies(POSES, "rigid,payload_mass,gravity_preload", m_p=5.0)
    np.testing.assert_allclose(fr[0], hz(Kr[0], Mr[0]), rtol=1e-9)
    # the exact condensation with the preload (rigid rods)
    ex = heli4.modes(POSES, "actuator_loss,ee_compliance,payload_mass,gravity_preload", m_p=5.0)
    pen = heli4.frequencies(POSES, "actuator_loss,ee_compliance,payload_mass,gravity_preload", m_p=5.0, c_rigid=1e-9)
    np.testing.assert_allclose(pen[:, :3], ex.freq_hz[:, :3], rtol=1e-7)


# ------------------------------------------------------------ derivatives
def test_matrix_derivatives_of_a_linear_stiffness(heli4):
    """K_R is linear in k_a and in eta_a (the actuators' stiffness eta_a k_a), M depends on
    neither: central differences inside the bounds, second-order one-sided at eta_a = 1 (its
    upper bound), each pose at its own value."""
    k_a = np.array([2000.0, 3000.0])
    d = heli4.matrix_derivatives(POSES, ["k_a", "eta_a"], k_a=k_a, eta_a=1.0)
    scale = np.abs(d["K_R"]).max()
    np.testing.assert_allclose(d["dK_R"][:, 0], d["K_R"] / k_a[:, None, None], atol=1e-9 * scale / 2000)
    np.testing.assert_allclose(d["dK_R"][:, 1], d["K_R"], atol=1e-9 * scale)
    assert np.abs(d["dM"]).max() < 1e-9 * np.abs(d["M"]).max()
    assert d["dK_F"].shape == (2, 2, 6, 6)
    inside = heli4.matrix_derivatives(POSES, ["eta_a"], "paper", eta_a=0.5)
    np.testing.assert_allclose(inside["dK_R"][:, 0], inside["K_R"] / 0.5, atol=1e-9 * scale)
    # the model is the one asked for: the rigid model's K_F has no rod compliance
    r = heli4.matrix_derivatives(POSES, ["k_a"], "rigid")
    np.testing.assert_array_equal(r["K_F"], heli4.matrices(POSES, "rigid")["K_F"])
    # the lower bound: one row at 1e-7 leaves no step either way
    with pytest.raises(
        InputError,
        match=r"^parameter 'eta_a' = 1: no difference step of 1e-05 either way stays within its bounds and "
        r"constraints; expected a value away from them$",
    ):
        heli4.matrix_derivatives(POSES, ["eta_a"], eta_a=np.array([1.0, 1e-7]))
    low = heli4.matrix_derivatives(POSES, ["eta_a"], eta_a=np.array([1.0, 2e-5]))  # one-sided downwards
    np.testing.assert_allclose(
        low["dK_R"][:, 0], low["K_R"] / np.array([1.0, 2e-5])[:, None, None], rtol=1e-6, atol=1e-9 * scale
    )


def test_frequency_sensitivities_by_differences(heli4):
    """d f / d k_a of the rigid model: f ~ sqrt(k_a), so d f / d k_a = f / (2 k_a)."""
    m, d = heli4.modes_and_sensitivities(POSES, ["k_a"], "rigid", method="differences", k_a=2500.0)
    np.testing.assert_allclose(d[..., 0], m.freq_hz / (2 * 2500.0), rtol=1e-7)
    assert m.stiffness_model == "rigid" and m.axes == ("x", "y", "z")
    np.testing.assert_allclose(m.freq_hz, heli4.frequencies(POSES, "rigid", k_a=2500.0), rtol=1e-12)
    mf, df = heli4.modes_and_sensitivities(POSES, ["k_a"], method="differences")
    assert mf.stiffness_model == "flexible" and df.shape == (2, 6, 1)
    np.testing.assert_allclose(mf.freq_hz, heli4.frequencies(POSES), rtol=1e-9)
    assert (df[:, :3, 0] > 0).all()  # the actuators stiffen the three low modes
    with pytest.raises(
        InputError, match=r"^joint_sensitivities of heli4: its legs have a closed-form inverse kinematics"
    ):
        heli4.joint_sensitivities(POSES)


def test_sensitivities_where_rods_are_rigid_are_those_of_the_exact_modes(heli4):
    model = "actuator_loss,ee_compliance"
    m, d = heli4.modes_and_sensitivities(POSES[:1], ["k_a"], model, method="differences")
    exact = heli4.modes(POSES[:1], model)
    np.testing.assert_allclose(m.freq_hz[:, :3], exact.freq_hz[:, :3], rtol=1e-12)
    assert m.legs is None and m.constrained[0].tolist() == [False] * 3 + [True] * 3
    # against central differences of the exact frequencies themselves
    h = 2500.0 * 1e-4
    fd = (heli4.frequencies(POSES[:1], model, k_a=2500.0 + h) - heli4.frequencies(POSES[:1], model, k_a=2500.0 - h)) / (
        2 * h
    )
    m2, d2 = heli4.modes_and_sensitivities(POSES[:1], ["k_a"], model, method="differences", k_a=2500.0)
    np.testing.assert_allclose(d2[0, :3, 0], fd[0, :3], rtol=5e-5)  # the penalty's derivative, Richardson-corrected


# ------------------------------------------------------- per-pose values
def test_the_lever_is_relative_to_each_poses_own_l1(heli4, hexapod):
    P = np.array([POSES[0], [0.0, 0.0, -1.2], POSES[1]])
    l1 = np.array([0.2, 0.21, 0.19])
    st = heli4.pose_status(P, l1=l1, k_a=np.array([1.0, 2.0, 3.0]))
    assert st["status"].tolist() == ["reachable", "unreachable", "reachable"]
    lever = heli4.jacobians(P[[0, 2]], l1=l1[[0, 2]])["lever"]
    np.testing.assert_allclose(st["lever"][[0, 2]], np.abs(lever).min(axis=1) / l1[[0, 2]], rtol=1e-12)
    assert heli4.valid(P, l1=l1).tolist() == [True, False, True]
    # no l1 (the hexapod): the lever as the kernel gives it
    x = np.array([hexapod.robot.x_ref, [0.02, 0.0, 0.8, 0.0, 0.05, 0.1]])
    sh = hexapod.pose_status(x)
    assert sh["status"].tolist() == ["reachable", "reachable"]
    np.testing.assert_allclose(sh["lever"], np.abs(hexapod.jacobians(x)["lever"]).min(axis=1), rtol=1e-12)


def test_a_long_batch_keeps_each_poses_status(heli4):
    n = CHUNK + 3
    P = np.tile(POSES[0], (n, 1))
    P[1] = P[-2] = [0.0, 0.0, -1.2]
    st = heli4.pose_status(P)
    expected = np.zeros(n, dtype=np.int8)
    expected[[1, n - 2]] = 1
    np.testing.assert_array_equal(st["code"], expected)
    np.testing.assert_array_equal(heli4.valid(P), expected == 0)
    assert np.isnan(st["conditioning"][n - 2]) and np.isfinite(st["conditioning"][n - 1])


def test_a_kernels_outputs_come_with_the_joints_it_was_run_at(heli4):
    out = heli4.run_kernel("gravity", POSES, "paper,gravity_preload")
    np.testing.assert_array_equal(out["q"], heli4.joint_angles(POSES))
    assert {"J_rows", "lever", "G"} <= set(out) and len(out["G"]) == 2
    jac = heli4.jacobians(POSES)
    assert set(jac) == {"q", "J_rows", "lever"}
    np.testing.assert_array_equal(jac["J_rows"], out["J_rows"])
    with pytest.raises(UnreachablePoseError):
        heli4.run_kernel("gravity", [[0.0, 0.0, -1.2]], "paper,gravity_preload")


def test_damped_modes_of_a_batch_with_an_invalid_pose(heli4):
    P = np.array([POSES[0], [0.0, 0.0, -1.2], POSES[1]])
    m = heli4.modes(P, "damped", invalid="nan", k_a=np.array([2000.0, 2100.0, 2200.0]))
    assert m.valid.tolist() == [True, False, True] and m.stable.tolist() == [True, True, True]
    assert np.isnan(m.natural_hz[1]).all() and np.isfinite(m.natural_hz[[0, 2]]).all()
    alone = heli4.modes(POSES[1:], "damped", k_a=2200.0)
    np.testing.assert_allclose(m.natural_hz[2], alone.natural_hz[0], rtol=1e-9)
    np.testing.assert_allclose(m.damping_ratio[2], alone.damping_ratio[0], rtol=1e-7, atol=1e-12)
    assert (m.damping_ratio[[0, 2], :3] > 0).all()  # the servo damping damps the actuated modes
    none = heli4.modes([[0.0, 0.0, -1.2]], "damped", invalid="nan")
    assert np.isnan(none.freq_hz).all() and none.stable.all()


def test_complex_shapes_of_an_undamped_model_are_its_eigentwists(heli4):
    m = heli4.modes(POSES, "paper", complex_shapes=True)
    assert m.damping is not None and m.complex_eigentwists.shape == (2, 6, 6)
    np.testing.assert_allclose(m.natural_hz, m.freq_hz, rtol=1e-9)
    assert np.abs(m.damping_ratio).max() < 1e-9
    np.testing.assert_allclose(m.complex_eigentwists.real, m.eigentwists, atol=1e-7)
    assert np.abs(m.complex_eigentwists.imag).max() < 1e-7
    r = heli4.modes(POSES, "rigid", complex_shapes=True)
    assert r.complex_eigentwists.shape == (2, 3, 3)
    np.testing.assert_allclose(r.natural_hz, r.freq_hz, rtol=1e-9)


def test_kernels_without_a_legs_kernel_keep_K_F_and_refuse_damping(heli4):
    module = types.ModuleType("heli4_without_legs")
    module.__dict__.update({k: v for k, v in vars(heli4.module).items() if not k.startswith("__")})
    module.OUTPUTS = {k: v for k, v in heli4.module.OUTPUTS.items() if k != "legs"}
    ev = Evaluator(heli4.robot, module, "numpy")
    assert ev.constraint_route("paper") == ({}, False)
    assert ev.constraint_route("actuator_loss,ee_compliance") == ({}, False)  # no condensation without it
    with pytest.raises(
        InputError,
        match=r"^damped modes of heli4: its generated code has no legs kernel \(joint compliances\); regenerate it$",
    ):
        ev.modes(POSES, "paper,servo_damping")


def test_an_unreachable_reference_is_condensed_at_every_pose(heli4):
    """The route probes the legs at x_ref; where x_ref is out of reach (a short l2) every pose
    is solved by the exact condensation, which gives the same finite modes."""
    model = "actuator_loss,rod_compliance"
    assert heli4.constraint_route(model)[1] is False
    assert fresh().constraint_route(model, l2=0.3)[1] is True
    P = np.array([[0.0, 0.0, -0.4]])
    exact = fresh().frequencies(P, model, l2=0.3)
    # the route probed at the default x_ref (reachable): K_F with c_rigid = 0, the same modes
    np.testing.assert_allclose(exact, heli4.frequencies(P, model, l2=0.3), rtol=1e-9)


def test_a_new_evaluator_holds_what_it_was_given():
    from eigentwist.robots import get

    robot = get("heli4")
    module = fresh().module
    ev = Evaluator(robot, module, "numpy")
    assert ev.module is module and ev.kernels is module and ev.backend == "numpy" and ev.robot is robot
    assert ev.threads is None and ev.defaults == robot.defaults and ev.spec == "heli4"
    assert ev.pose_names == ("x", "y", "z") and ev.n_legs == 4 and ev.effects == robot.effects
    assert set(ev.leg_parameters) == {"eta_a", "E_rod", "G_rod", "r_o_l1", "r_i_l1", "E_l1", "nu_l1", "k_t", "I_add"}
    assert ev.leg_parameters["k_t"] == "transmission_compliance"
    assert Evaluator(robot, module, "numpy", threads=2).threads == 2
    with pytest.raises(InputError, match=r"^threads = 0: expected a whole number of threads >= 1$"):
        Evaluator(robot, module, "numpy", threads=0)
    assert not ev.numeric_ik and ev.completion.follower_reference() is None
    # a six-coordinate platform: its kernels read the pose by name, rotation included
    hx = Evaluator(get("hexapod"), eigentwist.load("hexapod", backend="numpy").module, "numpy")
    x = np.array([[0.0, 0.0, 0.8, 0.0, 0.0, 0.0], [0.0, 0.0, 0.8, 0.0, 0.0, 0.2]])
    f = hx.frequencies(x, "rigid")
    assert np.isfinite(f).all() and not np.allclose(f[0], f[1])  # the rotation is read
    assert set(hx.completion.with_pose(x, {})) >= {"R_00", "rot_z"} and "R_00" not in ev.completion.with_pose(POSES, {})


def test_two_poses_one_invalid_with_values_per_pose(heli4):
    """Two poses are a batch: the valid one keeps its own value of each per-pose parameter."""
    P = np.array([POSES[0], [0.0, 0.0, -1.2]])
    st = heli4.pose_status(P, l1=np.array([0.19, 0.2]))
    lever = heli4.jacobians(P[:1], l1=0.19)["lever"]
    np.testing.assert_allclose(st["lever"][0], np.abs(lever).min() / 0.19, rtol=1e-12)
    assert heli4.valid(P, l1=np.array([0.19, 0.2])).tolist() == [True, False]
    k_a = np.array([3000.0, 2000.0])
    m = heli4.modes(P, "rigid", invalid="nan", k_a=k_a)
    np.testing.assert_allclose(m.freq_hz[0], heli4.frequencies(POSES[:1], "rigid", k_a=3000.0)[0], rtol=1e-12)
    d = heli4.modes(P, "damped", invalid="nan", k_a=k_a)
    np.testing.assert_allclose(d.natural_hz[0], heli4.modes(POSES[:1], "damped", k_a=3000.0).natural_hz[0], rtol=1e-9)
    with pytest.raises(
        InputError, match=r"^parameter 'k_a' has shape \(3,\): expected a scalar or \(2,\) for 2 poses$"
    ):
        heli4.parameter_values(2, k_a=np.ones(3))


def test_measured_joints_take_the_models_route(heli4, hexapod):
    q = heli4.joint_angles(POSES)
    model = "actuator_loss,ee_compliance"  # rigid rods: the exact condensation
    by_joints = heli4.modes(None, model, joints=q, unstable="raise")
    by_poses = heli4.modes(POSES, model)
    np.testing.assert_allclose(by_joints.freq_hz[:, :3], by_poses.freq_hz[:, :3], rtol=1e-12)
    np.testing.assert_allclose(by_joints.eigentwists[:, :, :3], by_poses.eigentwists[:, :, :3], atol=1e-9)
    assert by_joints.legs is None and by_joints.constrained[0].tolist() == [False] * 3 + [True] * 3
    r = heli4.modes(None, "rigid", joints=q, vectors=False)
    assert r.eigentwists is None and r.stiffness_model == "rigid"
    np.testing.assert_allclose(r.freq_hz, heli4.frequencies(POSES, "rigid"), rtol=1e-12)
    mats = heli4.joint_matrices(POSES, q)
    np.testing.assert_allclose(mats["K_F"], heli4.matrices(POSES)["K_F"], rtol=1e-12)
    x = np.array([hexapod.robot.x_ref])
    h = hexapod.modes(x, "rigid", joints=hexapod.joint_angles(x))
    assert h.stiffness_model == "rigid" and h.axes == AXES  # six allowed twists, still the rigid model
    with pytest.raises(
        InputError, match=r"^parameter 'k_a' has shape \(3,\): expected a scalar or \(2,\) for 2 poses$"
    ):
        heli4.joint_matrices(POSES, q, k_a=np.ones(3))


def test_the_serial_singularity_threshold_on_either_side(heli4):
    """The lever relative to l1 at the LEVER_TOL = 1e-3 edge: near the Heli4's singular z the
    lever grows as sqrt(z - z_s) (~3.7 sqrt(dz / m)), so dz = 4e-8 m lies inside (7e-4) and
    3e-7 m outside (2e-3), where the lever itself (l1 = 0.2 m) is still below 1e-3."""
    inside = np.array([[0.0, 0.0, singular_z(heli4) - 1e-9 + 4e-8]])
    outside = np.array([[0.0, 0.0, singular_z(heli4) - 1e-9 + 3e-7]])
    st = heli4.pose_status(np.concatenate([inside, outside]))
    assert st["status"].tolist() == ["serial singular", "reachable"]
    assert 5e-4 < st["lever"][0] < 1e-3 < st["lever"][1] < 3e-3
    assert heli4.valid(np.concatenate([inside, outside])).tolist() == [False, True]
    assert np.isfinite(heli4.frequencies(outside)).all()
    q = heli4.joint_angles(outside)
    np.testing.assert_allclose(heli4.frequencies(None, joints=q), heli4.frequencies(outside), rtol=1e-9)
    with pytest.raises(SingularPoseError, match="leg 1"):
        heli4.frequencies(inside)
    p = heli4.completion.with_pose(inside, heli4.resolver.resolve(1, {}, "paper"))
    q_in = heli4.kernels.inverse_kinematics(inside[:, 0], inside[:, 1], inside[:, 2], p)["q"]
    with pytest.raises(SingularPoseError, match=r"leg 1.*lever"):
        heli4.frequencies(None, joints=q_in)


@pytest.mark.parametrize(
    "model, finite",
    [
        ("rigid,servo_damping", 3),
        ("rigid,payload_mass,gravity_preload,servo_damping", 3),
        ("paper,payload_mass,gravity_preload,servo_damping", 6),
        ("actuator_loss,ee_compliance,servo_damping", 3),  # rigid rods: the exact condensation
    ],
)
def test_light_damping_keeps_the_undamped_frequencies(heli4, model, finite):
    """c_a -> 0: each pole's modulus is the undamped natural frequency, its damping ratio small
    and positive (the damped modes solve the same M and K, preload and route included)."""
    undamped = model.replace(",servo_damping", "")
    d = heli4.modes(POSES, model, c_a=1e-6, m_p=2.0)
    f = heli4.frequencies(POSES, undamped, m_p=2.0)
    np.testing.assert_allclose(d.freq_hz[:, :finite], f[:, :finite], rtol=1e-12)
    np.testing.assert_allclose(d.natural_hz[:, :finite], f[:, :finite], rtol=1e-8)
    zeta = d.damping_ratio[:, :finite]
    assert (zeta[:, :3] > 0).all() and zeta.max() < 1e-5


def test_coupled_bodies_on_rigid_rods_are_condensed_exactly(heli4):
    model = "actuator_loss,ee_compliance,ee_coupling"
    assert heli4.constraint_route(model)[1]
    m = heli4.modes(POSES[:1], model)
    penalty = heli4.frequencies(POSES[:1], model, c_rigid=1e-9)
    finite = ~m.constrained[0]
    np.testing.assert_allclose(m.freq_hz[0, finite], penalty[0, : finite.sum()], rtol=1e-7)


def test_sensitivities_refuse_the_gravity_preload(heli4):
    with pytest.raises(InputError, match="gravity_preload"):
        heli4.sensitivities(POSES, ["k_a"], "paper,gravity_preload", method="differences")


def test_a_model_given_as_a_list_of_effects(heli4):
    f = heli4.frequencies(POSES, ["actuator_loss", "rod_compliance", "ee_compliance"], k_a=np.array([2000.0, 2100.0]))
    np.testing.assert_allclose(f, heli4.frequencies(POSES, "paper", k_a=np.array([2000.0, 2100.0])), rtol=1e-12)


def test_one_sided_derivatives_at_the_lower_bound_and_the_results_shapes(heli4):
    low = heli4.matrix_derivatives(POSES, ["eta_a"], eta_a=5e-6)  # eta_a - h leaves (0, 1]: one-sided upwards
    np.testing.assert_allclose(low["dK_R"][:, 0], low["K_R"] / 5e-6, rtol=1e-6)
    m, _ = heli4.modes_and_sensitivities(POSES, ["k_a"], method="differences")
    assert m.stable.shape == (2,) and m.eigentwists.shape == (2, 6, 6)
    assert heli4.constraint_route() == heli4.constraint_route("paper")
    assert heli4.modes(POSES, "actuator_loss,ee_compliance").legs is None
    n = heli4.modes([[0.0, 0.0, -1.2], POSES[0]], invalid="nan")
    assert n.axes == AXES and n.stiffness_model == "flexible" and np.isfinite(n.eigentwists[1]).all()
    # the chunks of iter_matrices and the matrices at joints follow the model and the values given
    ((_, part),) = heli4.iter_matrices(POSES, "rigid", chunk=2, eta_a=0.5)
    np.testing.assert_array_equal(part["K_F"], heli4.matrices(POSES, "rigid", eta_a=0.5)["K_F"])
    q = heli4.joint_angles(POSES)
    at_joints = heli4.matrices(None, "rigid", joints=q, eta_a=0.5)
    np.testing.assert_allclose(at_joints["K_F"], part["K_F"], rtol=1e-12)
    with pytest.raises(
        InputError, match=r"not supported \(the damped modes need the pose's inverse kinematics\); give poses$"
    ):
        heli4.modes(None, joints=q, complex_shapes=True)


def test_a_heavy_preloaded_payload_is_unstable_where_its_pencil_has_a_negative_eigenvalue(heli4):
    """A 10 t payload hanging on the Heli4 (``gravity_preload``): its negative geometric
    stiffness outweighs the legs' at some poses. ``invalid="nan"`` marks exactly the poses
    whose pencil (K, M) has a negative eigenvalue (SciPy's solver here) unstable, with and
    without an unreachable pose in the batch, and keeps the others stable."""
    model, x = ("actuator_loss", "gravity_preload", "payload_mass"), np.array([[0, 0, -0.625], [0.05, 0.02, -0.6]])
    M, K = heli4.stiffness(x, model, m_p=1e4)
    negative = [scipy.linalg.eigh(k, m, eigvals_only=True)[0] < 0 for k, m in zip(K, M)]
    assert negative == [False, True]  # one pose of each kind
    every = heli4.modes(x, model, invalid="nan", m_p=1e4)
    assert every.stable.tolist() == [True, False] and every.valid.tolist() == [True, True]
    assert np.isnan(every.freq_hz[1, 0]) and np.isfinite(every.freq_hz[0]).all()
    some = heli4.modes(np.vstack([x, [0.0, 0.0, 5.0]]), model, invalid="nan", m_p=1e4)
    assert some.valid.tolist() == [True, True, False] and some.stable[:2].tolist() == [True, False]
    np.testing.assert_allclose(some.freq_hz[:2], every.freq_hz, rtol=1e-12)  # each pose solved on its own
