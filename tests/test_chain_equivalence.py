"""The Heli4 and Delta as joint lists give every output they gave before (issue 15).

``tests/data/chain_pin.npz`` holds every output of the evaluators generated from the
hand-built RR(Pi)RR leg (wrenches written out in ``symbolic/leg.py``, before issue 15),
at 20 reachable poses per robot, with every effect off, every effect on at the default
values, and every effect on at moved values (each leg its own); see
``tests/data/make_chain_pin.py``. The evaluators generated today (from the joint lists
through Huang's method from 5x5 minors; ``tests/test_generated.py`` checks that they are
the derivation's) must give the same numbers to 1e-12 relative to each output's largest
entry, pose by pose (an entry pinned as all zeros at a pose must stay zero there).
"""
from __future__ import annotations

from importlib import import_module
from pathlib import Path

import numpy as np
import pytest

PIN = np.load(Path(__file__).parent / "data" / "chain_pin.npz")
GROUPS = ("inverse_kinematics", "matrices", "jacobians", "gravity")
CASES = [(r, c) for r in ("heli4", "delta") for c in ("bare", "on", "custom")]


def _outputs(robot: str, case: str) -> dict:
    mod = import_module(f"eigentwist.generated.{robot}_numpy")
    p = dict(zip(PIN[f"{robot}/{case}/names"].tolist(), PIN[f"{robot}/{case}/values"]))
    poses = PIN[f"{robot}/poses"]
    ik = mod.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
    out = {"inverse_kinematics": ik}
    for g in GROUPS[1:]:
        out[g] = getattr(mod, g)(ik["q"], p)
    return out


@pytest.mark.parametrize("robot, case", CASES)
def test_every_output_equals_the_pinned_one(robot, case):
    got = _outputs(robot, case)
    n = len(PIN[f"{robot}/poses"])
    checked = 0
    for g in GROUPS:
        for name, value in got[g].items():
            want = PIN[f"{robot}/{case}/{g}/{name}"]
            value = np.broadcast_to(value, want.shape)
            scale = np.abs(want).reshape(n, -1).max(axis=1)
            err = np.abs(value - want).reshape(n, -1).max(axis=1)
            # an output pinned as zeros at a pose (sin q3 at x_ref, W without gravity) stays zero
            assert np.all(err <= 1e-12 * scale + 1e-300), \
                f"{robot} {case} {g}/{name}: relative error {np.max(err / scale):.3g} (pose {np.argmax(err / scale)})"
            checked += 1
    assert checked == 3 + 3 + 2 + 4                    # q, sin_q3, cos_q2; M, K_R, K_F; J_rows, lever; G, Kqe, k_act, W


def test_the_pin_covers_effects_that_change_the_outputs():
    """The three cases differ where the effects act: the pin can tell them apart."""
    for robot in ("heli4", "delta"):
        bare, on, custom = (PIN[f"{robot}/{c}/matrices/K_F"] for c in ("bare", "on", "custom"))
        assert np.abs(on - bare).max() > 1e-3 * np.abs(bare).max()
        assert np.abs(custom - on).max() > 1e-3 * np.abs(on).max()
        W = PIN[f"{robot}/on/gravity/W"]
        assert np.abs(W).max() > 0 and np.abs(PIN[f"{robot}/bare/gravity/W"]).max() == 0
