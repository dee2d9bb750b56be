"""Sensitivities of a flexible model on a lower-mobility platform: the followers (x, y,
rot_z of a 3-RPS) move with the geometry's parameters, and the frequencies' derivatives
follow them.

Expectations: central differences of the frequencies at the commanded poses (each
difference re-solves the followers), written here; the followers' own motion by
differences of the completed poses."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eigentwist

DESCRIPTION = Path(__file__).resolve().parent / "descriptions" / "rps3_flex.py"
MODEL = "strut_bending"
C_RIGID = 1e-10  # a stated compliance of the constrained directions: K_F is the model, no penalty stand-in
#: the reference's error: truncation ~(1e-5)^2, round-off ~1e-16 / 1e-5 times K_F's conditioning
RTOL = 1e-7
#: commanded (z, rot_x, rot_y): tilted (the followers move with R_p) and untilted (they do not)
POSES = np.array([[0.40, 0.15, -0.10], [0.40, 0.0, 0.0]])


@pytest.fixture(scope="module")
def ev():
    return eigentwist.load(str(DESCRIPTION), backend="numpy", progress=None)


def frequency_differences(ev, name: str, params: dict, rel: float = 1e-5) -> np.ndarray:
    v = ev.defaults[name]
    h = rel * abs(v)
    hi = ev.frequencies(POSES, MODEL, **params, **{name: v + h})
    lo = ev.frequencies(POSES, MODEL, **params, **{name: v - h})
    return (hi - lo) / (2 * h)


def test_the_followers_move_with_the_platform_radius_when_tilted(ev):
    v, h = ev.defaults["R_p"], 1e-6
    dx = (np.asarray(ev.completed_poses(POSES, R_p=v + h)) - np.asarray(ev.completed_poses(POSES, R_p=v - h))) / (2 * h)
    assert np.abs(dx[0, [0, 1]]).min() > 1e-3  # m/m: x and y of the tilted pose
    assert np.abs(dx[1]).max() < 1e-9 and np.abs(dx[:, 2:5]).max() < 1e-9  # untilted; commanded fixed


@pytest.mark.parametrize("params", [{"c_rigid": C_RIGID}, {}], ids=["stated_compliance", "exact_condensation"])
@pytest.mark.parametrize("method", ["differences", "exact"])
def test_sensitivities_equal_differences_of_the_frequencies(ev, method, params):
    """With c_rigid stated, K_F is the model; with its default, the frequencies come from the
    exact condensation and their derivatives from K_F's penalty, extrapolated to none."""
    wrt = ("R_p", "R_b", "m_pl", "c_b")
    assert ev.stiffness_model(MODEL) == "flexible"
    assert ev.constraint_route(MODEL, **params)[1] == (not params)
    got = ev.sensitivities(POSES, wrt=wrt, model=MODEL, method=method, **params)
    for j, name in enumerate(wrt):
        want = frequency_differences(ev, name, params)
        scale = np.abs(want).max(axis=1, keepdims=True)
        np.testing.assert_array_less(np.abs(got[..., j] - want) / scale, RTOL, err_msg=f"{name} ({method})")


def test_follower_terms_vanish_where_the_followers_stay(ev):
    from eigentwist.runtime.implicit import follower_terms

    params = {"c_rigid": C_RIGID}
    full = ev.completed_poses(POSES, **params)
    terms = follower_terms(ev, POSES, full, ("R_p", "m_pl"), MODEL, params)
    dK = terms["dK_F"]
    assert np.abs(dK[0, 0]).max() > 1e-3 * np.abs(ev.matrices(full, MODEL, **params)["K_F"][0]).max()
    assert not dK[1, 0].any()  # untilted: the followers do not move with R_p
    assert not dK[:, 1].any()  # a mass moves no follower
