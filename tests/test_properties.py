"""Property tests (hypothesis) of physics identities over the workspace."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import eigentwist

EV = eigentwist.load("heli4", backend="numpy")
(XL, XH), (YL, YH), (ZL, ZH) = EV.robot.workspace

poses = st.tuples(st.floats(XL, XH), st.floats(YL, YH), st.floats(ZL, ZH))
stiffness = st.floats(50.0, 10000.0)
models = st.sampled_from(["rigid", "paper", "coupled", "paper,lower_link_compliance,payload_mass,rotor_inertia"])


@settings(max_examples=40, deadline=None)
@given(pose=poses, k_a=stiffness, model=models)
def test_mirror_symmetry_of_the_heli4(pose, k_a, model):
    """Legs 1/2 mirror each other in x, legs 3/4 in y: frequencies are even in x and y."""
    x, y, z = pose
    f = EV.frequencies([[x, y, z], [-x, y, z], [x, -y, z], [-x, -y, z]], model, k_a=k_a)
    np.testing.assert_allclose(f[1:], np.broadcast_to(f[0], f[1:].shape), rtol=1e-8)


@settings(max_examples=40, deadline=None)
@given(pose=poses, k_a=stiffness, model=models)
def test_frequencies_positive_finite_and_eigentwists_normalised(pose, k_a, model):
    m = EV.modes([pose], model, k_a=k_a)
    assert np.isfinite(m.freq_hz).all() and (m.freq_hz > 0).all()
    assert (np.diff(m.freq_hz, axis=1) >= 0).all()
    top = np.take_along_axis(m.eigentwists, np.argmax(np.abs(m.eigentwists), axis=1)[:, None, :], axis=1)
    np.testing.assert_allclose(top, 1.0)


@settings(max_examples=25, deadline=None)
@given(pose=poses, k_a=stiffness, c=st.floats(0.1, 10.0))
def test_actuator_stiffness_scales_rigid_frequencies_by_sqrt_c(pose, k_a, c):
    f0 = EV.frequencies([pose], "rigid", k_a=k_a)
    f1 = EV.frequencies([pose], "rigid", k_a=c * k_a)
    np.testing.assert_allclose(f1, np.sqrt(c) * f0, rtol=1e-9)


@settings(max_examples=25, deadline=None)
@given(pose=poses, k_a=stiffness)
def test_structural_compliance_only_lowers_frequencies(pose, k_a):
    """Adding compliance in series cannot raise a natural frequency (Rayleigh)."""
    f_rigid_platform = EV.frequencies([pose], "actuator_loss,rod_compliance", k_a=k_a)
    f_paper = EV.frequencies([pose], "paper", k_a=k_a)
    f_coupled = EV.frequencies([pose], "coupled", k_a=k_a)
    assert (f_paper <= f_rigid_platform * (1 + 1e-9)).all()
    assert (f_coupled <= f_rigid_platform * (1 + 1e-9)).all()


def test_hypothesis_draws_no_constants_from_generated_modules():
    """tests/conftest.py leaves the generated evaluators out of the modules Hypothesis
    draws constants from; the hand-written ones stay in."""
    from pathlib import Path

    from hypothesis.internal.conjecture import providers

    import eigentwist.runtime.eigen as hand_written
    from eigentwist.generated import heli4_numpy as generated

    from .conftest import GENERATED_HEADER

    assert Path(generated.__file__).read_bytes().startswith(GENERATED_HEADER)
    assert not providers.is_local_module_file(generated.__file__)
    assert providers.is_local_module_file(hand_written.__file__)
