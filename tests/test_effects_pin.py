"""Every preset and single-effect output equals the one pinned before the effects-as-data
redesign, to 1e-12 relative to each matrix's largest entry.

Frequencies are compared to 1e-12 of the largest one, or to what a change of the
matrices at the level of round-off (1e-14 of K's largest entry) may move them, whichever
is larger (Weyl: a symmetric change dK moves each eigenvalue of (K, M) by at most
||dK|| / lambda_min(M)). The second bound matters only where K is ill-conditioned: with
the legs' constrained directions rigid (c_rigid = 1e-12 rad/(N m), no rod compliance,
``ee_compliance`` or ``ee_coupling`` alone) K_F spans 1e12 N m/rad to 1e4 N/m and one
unit in the last place of its largest entry moves a 20 Hz frequency by ~1e-6 Hz; the
generic joint-list derivation rounds differently from the hand-built one.
A flexible model's frequencies from the evaluator come from the exact condensation of
the constraints (runtime/condense.py): they equal the pinned ones to the
penalty's error, and the pinned ones are those of the pinned matrices.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eigentwist
from eigentwist.description.effects import resolve_model
from eigentwist.runtime.eigen import frequencies_hz, generalized_eigh

PIN = np.load(Path(__file__).parent / "data" / "effects_pin.npz")
PARAMS = {"p_x": 0.01, "p_y": -0.02, "p_z": 0.03}  # as in tests/data/make_effects_pin.py
CASES = sorted({k.rsplit("/", 1)[0] for k in PIN.files if not k.endswith("/poses")})


@pytest.fixture(scope="module")
def evaluators():
    return {r: eigentwist.load(r, backend="numpy") for r in ("heli4", "delta")}


@pytest.mark.parametrize("case", CASES)
def test_outputs_equal_the_pinned_ones(evaluators, case):
    robot, model = case.split("/", 1)
    ev = evaluators[robot]
    poses = PIN[f"{robot}/poses"]
    mats = ev.matrices(poses, model, **PARAMS)
    freq = ev.frequencies(poses, model, **PARAMS)
    if ev.stiffness_model(resolve_model(model, ev.robot)) == "flexible":
        # the evaluator's finite modes are the exact condensation's, the pins K_F's
        # (c_rigid = 1e-12 rad/(N m)): they differ by the penalty, < 1e-5 relative; the
        # pinned frequencies are those of the pinned matrices (strictly, below)
        np.testing.assert_allclose(freq, PIN[f"{case}/freq_hz"], rtol=1e-5, err_msg=case)
        assert not np.allclose(freq, PIN[f"{case}/freq_hz"], rtol=1e-14, atol=0)  # exact, not the penalty's
        M, K = ev.stiffness(poses, model, **PARAMS)  # K_F (and the preload) as pinned
        freq = frequencies_hz(generalized_eigh(K, M)[0])
    got = {**mats, "freq_hz": freq}
    for key, value in got.items():
        want = PIN[f"{case}/{key}"]
        scale = np.abs(want).reshape(len(want), -1).max(axis=1)
        err = np.abs(value - want).reshape(len(want), -1).max(axis=1)
        if key == "freq_hz":
            err = np.max(np.abs(value - want) / np.maximum(1e-12 * scale[:, None], _round_off(case, want)), axis=1)
            assert np.all(err <= 1), f"{case} {key}: error {np.max(err):.3g} times the tolerance"
            continue
        assert np.all(err <= 1e-12 * scale), f"{case} {key}: relative error {np.max(err / scale):.3g}"


def _round_off(case: str, freq: np.ndarray) -> np.ndarray:
    """(poses, modes) bound on the change of each frequency (Hz) that a symmetric change of
    the pinned stiffness by 1e-14 of its largest entry can cause: ``|d lambda| <=
    ||dK||_2 / lambda_min(M)`` (Weyl; a principal block of M has no smaller eigenvalue),
    ``lambda = (2 pi f)^2``."""
    K = np.stack([PIN[f"{case}/{k}"] for k in ("K_R", "K_F")])
    dK = 6 * 1e-14 * np.abs(K).max(axis=(0, 2, 3))  # ||dK||_2 <= n max|dK_ij|
    lam_M = np.linalg.eigvalsh(PIN[f"{case}/M"])[:, 0]
    return (dK / lam_M)[:, None] / (8 * np.pi**2 * freq)
