"""The benchmark's per-pose baseline (benchmarks/reference_loop.py), written from the paper
with plain numerics (numeric inverse Jacobians and compliance inversions), equals the
generated evaluator: an independent computation of M, K_R, K_F and the frequencies."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from .conftest import random_poses

ROOT = Path(__file__).resolve().parents[1]
EXTRA = ("lower_link_compliance", "transmission_compliance", "payload_mass", "rotor_inertia")


@pytest.fixture(scope="module")
def ref():
    spec = importlib.util.spec_from_file_location("reference_loop", ROOT / "benchmarks" / "reference_loop.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _perturbed(ev, seed):
    """Defaults perturbed by up to +-10 % (payload offsets set to a few cm). A body's
    principal moments share one factor, so they keep satisfying the triangle inequality
    (the slender lower link sits close to its edge)."""
    rng = np.random.default_rng(seed)
    p = {k: v * (1 + 0.2 * (rng.random() - 0.5)) for k, v in ev.defaults.items()}
    for body in ("I1_", "I_e_"):
        factor = 1 + 0.2 * (rng.random() - 0.5)
        p.update({k: ev.defaults[k] * factor for k in p if k.startswith(body)})
    p.update(p_x=0.02 * rng.normal(), p_y=0.02 * rng.normal(), p_z=0.02 * rng.normal())
    return p


@pytest.mark.parametrize("seed, effects", [(1, ()), (2, EXTRA)])
def test_reference_loop_equals_generated_evaluator(ev, ref, seed, effects):
    p = _perturbed(ev, seed)
    poses = random_poses(ev.robot, 5, seed)
    model = ",".join(("paper",) + effects)
    got = ev.matrices(poses, model, **p)
    want = ref.matrices_loop(poses, p, ref.PAPER + effects)
    for key in ("M", "K_R", "K_F"):
        scale = np.abs(want[key]).max(axis=(1, 2), keepdims=True)
        np.testing.assert_allclose(got[key], want[key], rtol=0, atol=1e-9 * scale.max(), err_msg=key)
    np.testing.assert_allclose(
        ev.frequencies(poses, model, **p), ref.frequencies_loop(poses, p, ref.PAPER + effects), rtol=1e-9
    )


def test_reference_loop_rigid_frequencies(ev, ref):
    poses = random_poses(ev.robot, 4, seed=3)
    want = ref.frequencies_loop(poses, ev.defaults, ("actuator_loss",), rigid=True)
    np.testing.assert_allclose(ev.frequencies(poses, "rigid"), want, rtol=1e-9)
