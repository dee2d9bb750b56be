"""Write ``hexapod_pin.npz``: every output group of the hexapod's evaluator.

The hexapod was first derived by its own function (``derive_chain``); a later change folds it
into the one derivation every robot goes through. This script was run once on the code
before that change (commit b2ceb15) and its output is checked in;
``tests/test_chain_equivalence.py`` compares today's evaluator with it to 1e-12 relative
to each output's largest entry. It calls the generated NumPy module
(``eigentwist/generated/hexapod_numpy.py``) directly, without the runtime. Run it again
only to pin a deliberate change:

    python tests/data/make_hexapod_pin.py

Stored: ``hexapod/poses`` (N, 6): position (m) and rotation vector (rad) of the
platform, ``hexapod/R`` (N, 3, 3) their rotation matrices (Rodrigues' formula, here),
and per case (``bare``, ``on``, ``custom`` as in ``make_chain_pin.py``) the input names
and values and each output of ``inverse_kinematics``, ``matrices``, ``jacobians`` and
``gravity``.
"""

from __future__ import annotations

import sys
from importlib import import_module
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from make_chain_pin import N_POSES, inputs  # noqa: E402

ROBOT = "hexapod"


def rotation(r: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors ``r`` (N, 3) (axis x angle, rad)."""
    angle = np.linalg.norm(r, axis=1)
    k = r / np.where(angle > 0, angle, 1.0)[:, None]
    K = np.zeros((len(r), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K -= K.transpose(0, 2, 1)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1 - c) * K @ K


def pose_inputs(poses: np.ndarray, R: np.ndarray) -> dict:
    """The pose entries the generated kernels read from ``p``: x, y, z and R_ij."""
    out = {"x": poses[:, 0], "y": poses[:, 1], "z": poses[:, 2]}
    out.update({f"R_{i}{j}": R[:, i, j] for i in range(3) for j in range(3)})
    return out


def evaluate(mod, poses: np.ndarray, R: np.ndarray, p: dict) -> dict:
    pp = {**p, **pose_inputs(poses, R)}
    ik = mod.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], pp)
    groups = {"inverse_kinematics": ik}
    for g in ("matrices", "jacobians", "gravity"):
        groups[g] = getattr(mod, g)(ik["q"], pp)
    return groups


def pins() -> dict:
    mod = import_module(f"eigentwist.generated.{ROBOT}_numpy")
    desc = import_module(f"eigentwist.robots.{ROBOT}").describe()
    rng = np.random.default_rng(15)
    cases = {c: inputs(mod, c, rng) for c in ("bare", "on", "custom")}
    box = np.array(desc.workspace)
    pts = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((4 * N_POSES, 6))
    R = rotation(pts[:, 3:])
    ok = np.ones(len(pts), bool)
    for p in cases.values():
        ik = mod.inverse_kinematics(pts[:, 0], pts[:, 1], pts[:, 2], {**p, **pose_inputs(pts, R)})
        ok &= (np.abs(ik["cos_u"]) < 0.95).all(axis=1) & np.isfinite(ik["q"]).all(axis=(1, 2))
    poses = np.vstack([np.array(desc.x_ref), pts[ok][: N_POSES - 1]])
    R = np.concatenate([np.eye(3)[None], R[ok][: N_POSES - 1]])
    out = {f"{ROBOT}/poses": poses, f"{ROBOT}/R": R}
    for case, p in cases.items():
        out[f"{ROBOT}/{case}/names"] = np.array(list(p))
        out[f"{ROBOT}/{case}/values"] = np.array(list(p.values()))
        for g, res in evaluate(mod, poses, R, p).items():
            for k, v in res.items():
                out[f"{ROBOT}/{case}/{g}/{k}"] = np.broadcast_to(v, (len(poses),) + tuple(mod.OUTPUTS[g][k]))
    return out


if __name__ == "__main__":
    path = Path(__file__).with_name("hexapod_pin.npz")
    np.savez_compressed(path, **pins())
    print(f"wrote {path}")
