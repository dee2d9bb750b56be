"""The Heli4, Delta and hexapod give every output of their pinned hand-built derivations.

``tests/data/chain_pin.npz`` holds every output of the evaluators generated from the
hand-built RR(Pi)RR leg (wrenches written out in ``symbolic/leg.py``, commit 0f7cd9b),
at 20 reachable poses per robot, with every effect off, every effect on at the default
values, and every effect on at moved values (each leg its own); see
``tests/data/make_chain_pin.py``. The evaluators generated today (from the joint lists
through Huang's method from 5x5 minors; ``tests/test_generated.py`` checks that they are
the derivation's) must give the same numbers to 1e-12 relative to each output's largest
entry, pose by pose (1e-15 absolute where an output is pinned as all zeros at a pose).
``tests/data/hexapod_pin.npz`` holds the hexapod's outputs the same way (20 reachable
6-DoF poses, three cases; ``tests/data/make_hexapod_pin.py``), pinned before the hexapod
went through the one derivation every robot shares (pinned at commit b2ceb15). The
derivation itself, evaluated in SymPy arithmetic (``Program.evaluate``, 20 digits) without
any generated code, gives them too, at a few poses.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from eigentwist.robots import get
from eigentwist.symbolic import derive
from eigentwist.symbolic.model import EffectSymbols

DATA = Path(__file__).parent / "data"
PINS = {"chain": np.load(DATA / "chain_pin.npz"), "hexapod": np.load(DATA / "hexapod_pin.npz")}
PIN = {k: f[k] for f in PINS.values() for k in f.files}
GROUPS = ("inverse_kinematics", "matrices", "jacobians", "gravity")
CASES = [(r, c) for r in ("heli4", "delta", "hexapod") for c in ("bare", "on", "custom")]


def _pose_inputs(robot: str) -> dict:
    """The hexapod's pose entries of ``p`` (x, y, z m; R_ij of the pinned rotations)."""
    if robot != "hexapod":
        return {}
    poses, R = PIN["hexapod/poses"], PIN["hexapod/R"]
    out = {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}
    out.update({f"R_{i}{j}": R[:, i, j] for i in range(3) for j in range(3)})
    return out


def _pinned_inputs(robot: str, case: str) -> dict:
    """The pinned parameter inputs; the switch of an effect added after the pin (here:
    ``swinging_rods``) is off, so the pinned outputs still apply."""
    p = dict(zip(PIN[f"{robot}/{case}/names"].tolist(), PIN[f"{robot}/{case}/values"]))
    for name in EffectSymbols(get(robot)).switches():
        p.setdefault(name, np.zeros_like(PIN[f"{robot}/{case}/values"][0]))
    return p


def _outputs(robot: str, case: str) -> dict:
    mod = import_module(f"eigentwist.generated.{robot}_numpy")
    p = _pinned_inputs(robot, case)
    p.update(_pose_inputs(robot))
    poses = PIN[f"{robot}/poses"]
    ik = mod.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
    out = {"inverse_kinematics": ik}
    for g in GROUPS[1:]:
        out[g] = getattr(mod, g)(ik["q"], p)
    return out


def _close(value, want, n: int) -> np.ndarray:
    """Per pose: the error relative to the output's largest entry; where the pinned output
    is all zeros (sin q3 at x_ref, W without gravity) relative to 1e-3, i.e. 1e-15 absolute."""
    scale = np.abs(want).reshape(n, -1).max(axis=1)
    err = np.abs(np.broadcast_to(value, want.shape) - want).reshape(n, -1).max(axis=1)
    return err / np.where(scale > 0, scale, 1e-3)


@pytest.mark.derives
@pytest.mark.parametrize("robot", ["heli4", "delta", "hexapod"])
def test_the_derivation_gives_the_pinned_outputs(robot):
    """The one derivation's own programs, evaluated exactly, at two poses (the hexapod:
    one), every effect on at moved values (each leg its own)."""
    model = derive(get(robot))
    for case in ("custom",):
        p = _pinned_inputs(robot, case)
        for k in (7,) if robot == "hexapod" else (0, 7):  # the hexapod: a tilted pose (40 s each)
            x = PIN[f"{robot}/poses"][k]
            pose = {name: v[k] for name, v in _pose_inputs(robot).items()} or {"x": x[0], "y": x[1], "z": x[2]}
            ik = {
                name: np.array(model.ik.evaluate({**p, **pose}, sp.Matrix(ex), 20), dtype=float).reshape(shape)
                for name, (shape, ex) in model.ik_outputs.items()
            }
            q = {s_.name: v for s_, v in zip(model.joints, ik["q"].ravel())}
            got = {"inverse_kinematics": ik}
            # every output in one walk of the program (each intermediate evaluated once)
            outputs = [
                (g, name, shape, list(ex)) for g, outs in model.outputs.items() for name, (shape, ex) in outs.items()
            ]
            flat = sp.Matrix([e for *_, ex in outputs for e in ex])
            values = np.array(model.program.evaluate({**p, **pose, **q}, flat, 20), dtype=float).ravel()
            start = 0
            for g, name, shape, ex in outputs:
                got.setdefault(g, {})[name] = values[start : start + len(ex)].reshape(shape)
                start += len(ex)
            for g in GROUPS:
                for name, value in got[g].items():
                    want = PIN[f"{robot}/{case}/{g}/{name}"][k : k + 1]
                    assert _close(value[None], want, 1)[0] <= 1e-12, f"{robot} {case} pose {k}: {g}/{name}"


@pytest.mark.parametrize("robot, case", CASES)
def test_every_output_equals_the_pinned_one(robot, case):
    got = _outputs(robot, case)
    n = len(PIN[f"{robot}/poses"])
    checked = 0
    for g in GROUPS:
        for name, value in got[g].items():
            want = PIN[f"{robot}/{case}/{g}/{name}"]
            rel = _close(value, want, n)
            assert np.all(rel <= 1e-12), (
                f"{robot} {case} {g}/{name}: relative error {rel.max():.3g} (pose {rel.argmax()})"
            )
            checked += 1
    # q and the checks (sin_q3, cos_q2; the hexapod's cos_u); M, K_R, K_F; J_rows, lever; G, Kqe, k_act, W
    assert checked == (2 if robot == "hexapod" else 3) + 3 + 2 + 4


def test_the_pin_covers_effects_that_change_the_outputs():
    """The three cases differ where the effects act: the pin can tell them apart."""
    for robot in ("heli4", "delta", "hexapod"):
        bare, on, custom = (PIN[f"{robot}/{c}/matrices/K_F"] for c in ("bare", "on", "custom"))
        assert np.abs(on - bare).max() > 1e-3 * np.abs(bare).max()
        assert np.abs(custom - on).max() > 1e-3 * np.abs(on).max()
        W = PIN[f"{robot}/on/gravity/W"]
        assert np.abs(W).max() > 0 and np.abs(PIN[f"{robot}/bare/gravity/W"]).max() == 0
