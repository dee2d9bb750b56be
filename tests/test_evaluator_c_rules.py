"""The evaluator's C backend on a lower-mobility platform (the gallery's 3-PRS,
``examples/robots/prs3.py``: z, rot_x, rot_y commanded, x, y, rot_z following), against
the robot's geometry written here:

* the followers solved by the C driver close every leg's loop: each spherical joint
  ``top_i = p + R(rot) R_p e_r,i`` stays in its leg's plane, ``u_i . top_i = 0`` (``u_i`` the
  revolute axis, tangent to the base circle), and equal the NumPy iterations;
* the allowed twists from the C null space annihilate the legs' constraint wrenches (a force
  along ``u_i`` through ``top_i``; the twist's ``v`` the platform origin's velocity:
  ``u_i . (v + omega x (top_i - p)) = 0``), are orthonormal, and equal NumPy's;
* a follower that does not converge is refused in C as in NumPy, naming the pose; a rod too
  short to reach its column is refused naming the description's leg and the reach from
  the geometry.

On the shipped robots: the Heli4's prepared pass answers rows, one row, lists, float32 and
strided poses by itself and leaves bad shapes to the general route; damped modes with
complex shapes equal NumPy's; the Delta's parallel singular pose (its forearms horizontal)
is NaN and invalid through either C route.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import eigentwist
from eigentwist.runtime.errors import InputError, UnreachablePoseError

from .conftest import c_cache_dir, compiled_tier, random_poses

pytestmark = pytest.mark.compiled

PRS3 = Path(__file__).resolve().parent.parent / "examples" / "robots" / "prs3.py"
ANGLES = np.radians([90.0, 210.0, 330.0])
R_B, R_P = 0.30, 0.15  # the description's defaults (m)


@pytest.fixture(scope="module")
def rps():
    """The 3-PRS on the C backend (one thread) and on NumPy (generated and compiled once into
    the cache; the gallery's tests use the same)."""
    mp = compiled_tier()
    evc = eigentwist.load(str(PRS3), backend="c", threads=1, progress=None)
    ev = eigentwist.load(str(PRS3), backend="numpy", progress=None)
    yield evc, ev
    mp.undo()


def _poses():
    """Commanded (z, rot_x, rot_y): home, near it and spread over the workspace."""
    rng = np.random.default_rng(7)
    spread = np.column_stack([rng.uniform(0.56, 0.64, 12), rng.uniform(-0.1, 0.1, (12, 2))])
    return np.vstack([[0.60, 0.0, 0.0], [0.60, 1e-7, -1e-7], spread])


def _legs(full):
    """Each leg's plane normal u_i (3,) and spherical joint centre top_i (N, 3) at the full poses."""
    er = np.stack([np.cos(ANGLES), np.sin(ANGLES), np.zeros(3)], -1)
    u = np.stack([-np.sin(ANGLES), np.cos(ANGLES), np.zeros(3)], -1)
    R = Rotation.from_rotvec(full[:, 3:6]).as_matrix()
    top = full[:, None, :3] + np.einsum("nij,kj->nki", R, R_P * er)
    return u, top


def test_c_followers_close_every_legs_plane(rps, monkeypatch):
    evc, ev = rps
    assert evc.c_route.fused and evc.c_newton and "followers" in evc.kernels.OUTPUTS
    x = _poses()
    calls, follow = [], evc.kernels.follow  # the iterations run by the C driver
    monkeypatch.setattr(evc.kernels, "follow", lambda *a, **kw: calls.append(a[2]) or follow(*a, **kw))
    full = evc.completed_poses(x)
    assert calls and all(c == [0, 1, 5] for c in calls)  # x, y, rot_z of (x, y, z, rot_x, rot_y, rot_z)
    assert full.shape == (len(x), 6)
    np.testing.assert_array_equal(full[:, [2, 3, 4]], x)  # the commanded coordinates kept
    u, top = _legs(full)
    off = np.einsum("ki,nki->nk", u, top)
    assert np.abs(off).max() < 1e-10  # m: each S joint in its leg's plane
    assert np.abs(full[0, [0, 1, 5]]).max() < 1e-12  # home: no follower moves (symmetry)
    np.testing.assert_allclose(full, ev.completed_poses(x), rtol=0, atol=1e-12)
    # given back complete, nothing is solved again (the same array)
    assert evc.completed_poses(full) is full


def test_c_allowed_twists_annihilate_the_constraint_wrenches(rps, monkeypatch):
    from eigentwist.runtime import c_allowed

    evc, ev = rps
    x = _poses()
    calls, in_c = [], c_allowed.allowed_twists  # the null space computed by the C driver
    monkeypatch.setattr(c_allowed, "allowed_twists", lambda *a: calls.append(a[4]) or in_c(*a))
    B = evc.allowed_twists(x)
    # each leg's six joint rows (P, R, the S joint's three, the virtual one): the virtual joint's, the sixth
    assert len(calls) == 1 and list(calls[0]) == [5, 11, 17]
    assert B.shape == (len(x), 6, 3)
    np.testing.assert_allclose(np.einsum("nji,njk->nik", B, B), np.broadcast_to(np.eye(3), (len(x), 3, 3)), atol=1e-12)
    full = evc.completed_poses(x)
    u, top = _legs(full)
    arm, along = top - full[:, None, :3], np.broadcast_to(u, top.shape)
    wrench_rows = np.concatenate([np.cross(arm, along), along], -1)
    assert np.abs(np.einsum("nki,nij->nkj", wrench_rows, B)).max() < 1e-12
    np.testing.assert_allclose(B, ev.allowed_twists(x), rtol=0, atol=1e-12)


def test_c_follower_that_does_not_converge_is_named(rps, monkeypatch):
    from eigentwist.runtime import platform

    evc, _ = rps
    monkeypatch.setattr(platform, "MAX_STEPS", 1)
    x = np.array([[0.60, 0.09, -0.09]])
    assert np.isnan(evc.completed_poses(x)[0, [0, 1, 5]]).all()  # the followers NaN, not a nearby pose
    with pytest.raises(UnreachablePoseError) as err:
        evc.frequencies(x, "rigid")
    assert "z = 0.6, rot_x = 0.09, rot_y = -0.09 (m and rad) is unreachable for prs3" in str(err.value)


def test_c_pass_names_the_described_legs_check(rps):
    """A rod of 0.12 m at the second pose, shorter than the columns' reach (the S joints 0.15 m
    inside them): the C pass's refusal (of the frequencies and of the allowed twists) names the
    description's leg, the pose as given (z, rot_x, rot_y: the followers solved are not the
    user's coordinates) and the reach from the geometry, (e_r,1 . top_1 - R_b) / L."""
    import re

    evc, _ = rps
    x = np.array([[0.60, 0.0, 0.0], [0.62, 0.05, -0.02]])
    full = evc.completed_poses(x)
    _, top = _legs(full)
    reach = (top[1, 0] @ [np.cos(ANGLES[0]), np.sin(ANGLES[0]), 0.0] - R_B) / 0.12
    rods = np.array([0.40, 0.12])  # the first pose reachable, the second not
    with pytest.raises(UnreachablePoseError) as twists:
        evc.allowed_twists(x, L=rods)
    with pytest.raises(UnreachablePoseError) as err:
        evc.frequencies(x, "rigid", L=rods)
    assert str(twists.value) == str(err.value)
    m = re.fullmatch(
        r"pose \[(.*)\] \(m, rad\) is unreachable for leg 1: the leg cannot span that distance "
        r"\(reach = (.*), expected within \[-1, 1\]\)",
        str(err.value),
    )
    assert m is not None, str(err.value)
    np.testing.assert_allclose([float(v) for v in m.group(1).split(", ")], x[1], rtol=0, atol=1e-12)
    assert m.group(2) == f"{reach:.4g}"
    assert reach < -1


def test_c_modes_of_the_lower_mobility_platform_are_numpys(rps):
    """A lower-mobility platform's poses (z, rot_x, rot_y) are no columns of the prepared
    pass (it reads x, y, z): the general route, the modes of NumPy's matrices."""
    evc, ev = rps
    x = _poses()
    assert evc.c_route.plan("none", {}, "raise", "nan", True) is None
    for model in ("none", "rigid"):
        np.testing.assert_allclose(evc.frequencies(x, model), ev.frequencies(x, model), rtol=1e-9)


# ------------------------------------------------------------- the prepared pass (Heli4)
@pytest.fixture(scope="module")
def heli4():
    """The Heli4 on the C backend (one thread), a twin without the prepared pass, and poses
    valid in every model."""
    mp = compiled_tier()
    fast, general = (eigentwist.load("heli4", backend="c", threads=1) for _ in range(2))
    general.c_route.plan = lambda *args: None
    poses = random_poses(fast.robot, 40, seed=50)
    yield fast, general, poses[fast.valid(poses, "rigid") & fast.valid(poses, "paper")][:6]
    mp.undo()


def test_the_prepared_pass_answers_by_itself(heli4, monkeypatch):
    """Poses as one row, rows, a list, float32 or a strided view: the prepared pass's answer
    (the general route's bits), all stable, with ``unstable="raise"`` too, never handed to the
    general route (its first step fails here)."""
    fast, general, x = heli4
    for model in ("rigid", "paper"):  # the plans prepared (and remembered) first
        for unstable, invalid in (("nan", "raise"), ("raise", "nan"), ("nan", "nan")):
            fast.modes(x, model, unstable=unstable, invalid=invalid)

    def general_route(*args, **kw):
        raise AssertionError("the general route")

    monkeypatch.setattr(fast.solver, "route", general_route)
    flagged = np.vstack([x[:2], [0.0, 0.0, 0.0]])  # unreachable: checked with the pass's outputs
    got, want = fast.modes(flagged, "rigid", invalid="nan"), general.modes(flagged, "rigid", invalid="nan")
    assert got.valid.tolist() == [True, True, False] and got.freq_hz.tobytes() == want.freq_hz.tobytes()
    for P in (x, x[0], x.tolist(), x.astype(np.float32), np.asfortranarray(x)):
        for model in ("rigid", "paper"):
            want = general.modes(np.asarray(P, dtype=float), model)
            for unstable, invalid in (("nan", "raise"), ("raise", "nan")):
                got = fast.modes(P, model, unstable=unstable, invalid=invalid)
                assert got.freq_hz.tobytes() == want.freq_hz.tobytes()
                assert got.eigentwists.tobytes() == want.eigentwists.tobytes()
                assert isinstance(got.stable, np.ndarray) and got.stable.dtype == bool and got.stable.all()
                assert len(got.stable) == len(want.freq_hz)
                assert got.valid is None if invalid == "raise" else got.valid.tolist() == [True] * len(want.freq_hz)


@pytest.mark.parametrize(
    "poses, message",
    [
        (np.zeros((2, 2)), "poses has shape (2, 2): expected (N, 3) poses of heli4"),
        (np.zeros((2, 4)), "poses has shape (2, 4): expected (N, 3) poses of heli4"),
        (np.zeros((0, 3)), "poses is empty: expected at least one (x, y, z) pose (m)"),
        (np.zeros((1, 2, 3)), "poses has shape (1, 2, 3): expected (N, 3) poses of heli4"),
    ],
)
def test_the_prepared_pass_leaves_bad_shapes_to_the_general_route(heli4, poses, message):
    fast, _, _ = heli4
    assert fast.c_route.plan("rigid", {}, "raise", "nan", True)
    with pytest.raises(InputError) as err:
        fast.modes(poses, "rigid")
    assert str(err.value).startswith(message)


def test_damped_rigid_modes_with_complex_shapes_are_numpys(heli4):
    """The rigid model with a damping effect and complex shapes (the pass keeps its q, M and
    K_R for the damped modes), and with the gravity preload (nothing kept): NumPy's poles and
    complex eigentwists."""
    fast, _, x = heli4
    ev = eigentwist.load("heli4", backend="numpy")
    for model in ("rigid,gravity_preload,servo_damping", "paper,gravity_preload,servo_damping"):
        # the preload's general route keeps no kernel outputs on the C backend: computed for the poles
        got, want = (e.modes(x, model) for e in (fast, ev))
        np.testing.assert_allclose(got.natural_hz, want.natural_hz, rtol=1e-11)
        np.testing.assert_allclose(got.damping_ratio, want.damping_ratio, rtol=1e-9, atol=1e-12)
    flagged = np.vstack([x[:2], [0.0, 0.0, 0.0], x[2:4]])  # the middle pose unreachable
    for model in ("rigid,servo_damping", "paper,servo_damping"):
        for P, kw in ((x, {}), (flagged, dict(invalid="nan"))):
            got, want = (e.modes(P, model, complex_shapes=True, **kw) for e in (fast, ev))
            np.testing.assert_allclose(got.natural_hz, want.natural_hz, rtol=1e-11)
            np.testing.assert_allclose(got.damping_ratio, want.damping_ratio, rtol=1e-9, atol=1e-12)
            assert got.complex_eigentwists.shape == want.complex_eigentwists.shape
            assert np.array_equal(np.isnan(got.natural_hz), np.isnan(want.natural_hz))
        assert np.isnan(got.natural_hz[2]).all() and np.isfinite(np.delete(got.natural_hz, 2, 0)).all()


@pytest.mark.parametrize("model", ["paper", "rigid"])
def test_a_parallel_singular_pose_is_nan_through_either_c_route(model, monkeypatch):
    """The Delta with l2 = 0.4 m: at x = y = 0 its forearms lie horizontal where the elbows'
    radius R + l1 cos q1 reaches r_p + l2, at z = -sqrt(l1^2 - (l2 - R + r_p)^2); no actuator
    resists a vertical motion there. The C pass does not flag it (its legs are regular): the
    parallel check after it makes its frequencies and eigentwists NaN and the pose invalid, by
    the prepared pass (scalar values) and the general route (l2 per pose: the check reads the
    suspect pose's own value), or refuses it; 10 um below, the same check finds it regular
    (what it remembers is per pose)."""
    from eigentwist.runtime.errors import SingularPoseError

    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    ev = eigentwist.load("delta", backend="c", threads=1)
    d = ev.defaults
    z = -np.sqrt(d["l1"] ** 2 - (0.4 - d["R"] + d["r_p"]) ** 2)
    x = np.array([[0.0, 0.0, -0.25], [0.0, 0.0, z], [0.0, 0.0, -0.1]])
    for l2 in (0.4, np.full(3, 0.4)):
        modes = ev.modes(x, model, invalid="nan", l2=l2)
        assert modes.valid.tolist() == [True, False, True]
        assert np.isnan(modes.freq_hz[1]).all() and np.isnan(modes.eigentwists[1]).all()
        regular = ev.modes(x[[0, 2]], model, l2=0.4)
        np.testing.assert_allclose(modes.freq_hz[[0, 2]], regular.freq_hz, rtol=1e-12)
        np.testing.assert_allclose(modes.eigentwists[[0, 2]], regular.eigentwists, rtol=0, atol=1e-9)
        with pytest.raises(SingularPoseError, match="parallel singular"):
            ev.modes(x, model, l2=l2)
        assert ev.valid(x, model, l2=l2).tolist() == [True, False, True]  # said, not raised
        with pytest.raises(SingularPoseError, match="parallel singular"):
            ev.matrices(x, model, l2=l2)
        near = ev.modes(x[1] - [0.0, 0.0, 1e-5], model, invalid="nan", l2=l2 if np.ndim(l2) == 0 else l2[:1])
        assert near.valid.tolist() == [True] and np.isfinite(near.freq_hz).all()
