"""Sensitivities of a 6-DoF robot: the hexapod's generated dM/dp and
dK/dp give frequency derivatives equal to central differences of its evaluator, with the
rigid model's full 6x6 eigenproblem and the pose's rotation passed to the kernel."""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist

from .test_sensitivity import _assert_close, _central

WRT = ("k_a", "m_pl", "R_p", "d_cyl")
TILTED = np.array([[0.02, -0.03, 0.78, 0.05, -0.04, 0.1], [-0.05, 0.04, 0.83, -0.08, 0.06, -0.15]])


@pytest.fixture(scope="module")
def ev():
    return eigentwist.load("hexapod", backend="numpy")


@pytest.mark.parametrize("model", ["rigid", "paper"])
def test_hexapod_sensitivities_equal_central_differences(ev, model):
    dfdp = ev.sensitivities(TILTED, WRT, model)
    assert dfdp.shape == (2, 6, len(WRT))
    defaults = ev.robot.defaults
    for k, name in enumerate(WRT):
        want = _central(ev, TILTED, model, name, defaults[name], {})
        _assert_close(dfdp[:, :, k : k + 1], want[:, :, None])


def test_frequency_scales_with_the_square_root_of_k_a(ev):
    """Every K is proportional to k_a (no series effect in the rigid model): d ln f / d ln k_a = 1/2."""
    dfdp = ev.sensitivities(TILTED, ("k_a",), "rigid")
    f = ev.frequencies(TILTED, "rigid")
    np.testing.assert_allclose(dfdp[:, :, 0] * ev.robot.defaults["k_a"] / f, 0.5, rtol=1e-9)
