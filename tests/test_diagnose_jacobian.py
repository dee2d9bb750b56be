"""Exact Jacobians of the diagnosis' fits: generated sensitivities of the matched modes.

The fit's Jacobian in theta (ln p for positive parameters) must equal a Richardson-extrapolated
central difference of its own residuals, come from one kernel call per point (no extra
parameter sets), serve a per-leg candidate (``eta_a@3``) and fall back to differences, with
the reason recorded, where no sensitivity is generated (gravity preload).
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

import eigentwist
from eigentwist.diagnose import synth
from eigentwist.diagnose.fit import Transform, _Objective, fit
from eigentwist.diagnose.predict import Predictor

fit_module = importlib.import_module("eigentwist.diagnose.fit")  # the package re-exports fit()
POSES = ((0.0, 0.0, -0.625), (0.06, -0.04, -0.6))
KA = (250.0, 1000.0, 4000.0)


@pytest.fixture(scope="module")
def ev():
    return eigentwist.load("heli4", backend="numpy")


@pytest.fixture(scope="module")
def meas(ev):
    return synth(
        "rigid+payload_mass:m_p=0.35+actuator_loss@3:eta_a@3=0.7", KA, POSES, ("x", "y", "z"), 0.005, seed=4, ev=ev
    )


def _richardson_jacobian(obj, theta, h=1e-3):
    cols = []
    for j in range(len(theta)):
        e = np.zeros_like(theta)
        e[j] = 1.0
        d1 = (obj.residuals(theta + h * e) - obj.residuals(theta - h * e)) / (2 * h)
        d2 = (obj.residuals(theta + h / 2 * e) - obj.residuals(theta - h / 2 * e)) / h
        cols.append((4 * d2 - d1) / 3)
    return np.column_stack(cols)


@pytest.mark.parametrize("names", [("m_p",), ("m_p", "eta_a@3")])
def test_exact_jacobian_equals_central_differences_of_the_residuals(ev, meas, names):
    effects = ("actuator_loss@3", "payload_mass") if "eta_a@3" in names else ("payload_mass",)
    obj = _Objective(Predictor(meas, effects, ev), [Transform.of(ev.parameter(n)) for n in names], "exact")
    theta = np.array([math.log(0.3), math.log(0.8)][: len(names)])
    jac = obj.jacobian(theta)
    assert obj.exact and obj.nfev == 1  # one kernel call: residuals and Jacobian
    obj.residuals(theta)
    assert obj.nfev == 1
    want = _richardson_jacobian(obj, theta)
    scale = np.abs(want).max(axis=0)
    assert np.all(scale > 0)
    assert np.allclose(jac, want, rtol=1e-6, atol=1e-7 * scale)


def test_gravity_preload_falls_back_to_differences_and_says_why(ev, meas):
    res = fit(meas, ("payload_mass", "gravity_preload"), ev, ("m_p",), jacobian="exact")
    assert res.jacobian.startswith("central differences") and "gravity_preload" in res.jacobian
    exact = fit(meas, ("payload_mass", "actuator_loss@3"), ev, ("m_p",), fixed={"eta_a@3": 0.7}, jacobian="exact")
    assert exact.jacobian == "exact"
    assert exact.values["m_p"] == pytest.approx(res.values["m_p"], rel=0.5)  # same data, a nearby model


def test_exact_and_difference_fits_agree_within_their_uncertainty(ev, meas, monkeypatch):
    names = ("m_p", "eta_a@3")
    effects = ("payload_mass", "actuator_loss@3")
    exact = fit(meas, effects, ev, names, jacobian="exact")
    fd = fit(meas, effects, ev, names)  # the default: central differences
    assert exact.jacobian == "exact" and fd.jacobian.startswith("central differences")
    for n in names:
        assert abs(exact.values[n] - fd.values[n]) <= 1e-3 * exact.std[n]
        assert exact.std[n] == pytest.approx(fd.std[n], rel=1e-2)


def test_default_is_central_differences_and_the_kind_can_be_set_for_a_block(ev, meas):
    assert fit(meas, ("payload_mass",), ev, ("m_p",)).jacobian == "central differences"
    with fit_module.using_jacobian("exact"):
        assert fit(meas, ("payload_mass",), ev, ("m_p",)).jacobian == "exact"
    with pytest.raises(eigentwist.runtime.errors.InputError, match="jacobian 'fast'"):
        fit(meas, ("payload_mass",), ev, ("m_p",), jacobian="fast")
