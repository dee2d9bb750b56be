"""Every preset and single-effect output equals the one pinned before the effects-as-data
redesign (issue 11), to 1e-12 relative to each matrix's largest entry."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import eigentwist

PIN = np.load(Path(__file__).parent / "data" / "effects_pin.npz")
PARAMS = {"p_x": 0.01, "p_y": -0.02, "p_z": 0.03}      # as in tests/data/make_effects_pin.py
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
    got = {**mats, "freq_hz": ev.frequencies(poses, model, **PARAMS)}
    for key, value in got.items():
        want = PIN[f"{case}/{key}"]
        scale = np.abs(want).reshape(len(want), -1).max(axis=1)
        err = np.abs(value - want).reshape(len(want), -1).max(axis=1)
        assert np.all(err <= 1e-12 * scale), f"{case} {key}: relative error {np.max(err / scale):.3g}"
