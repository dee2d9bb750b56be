"""Write ``chain_pin.npz``: every output group of the Heli4 and Delta evaluators.

A later change turns the RR(Pi)RR legs of the Heli4 and the Delta into joint lists derived by
the generic chain code (Huang's method from 5x5 minors); every output must stay what it
was. This script was run once on the code before that change (the hand-built
``symbolic/leg.py`` wrenches, commit 0f7cd9b) and its output is checked in;
``tests/test_chain_equivalence.py`` compares today's evaluators with it to 1e-12 relative
to each output's largest entry. It calls the generated NumPy modules
(``eigentwist/generated/<robot>_numpy.py``) directly, without the runtime, so the pin
holds the derivation's own numbers. Run it again only to pin a deliberate change:

    python tests/data/make_chain_pin.py

Stored per robot: ``poses`` (N, 3) m, and per case (``bare``: defaults, every switch 0;
``on``: defaults, every switch 1; ``custom``: every parameter and each leg's copy moved
by a random factor in [0.95, 1.05], a payload offset, every switch 1) the input names and
values (``names``, ``values``) and each output of ``inverse_kinematics``, ``matrices``,
``jacobians`` and ``gravity``.
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path

import numpy as np

ROBOTS = ("heli4", "delta")
N_POSES = 20


def inputs(mod, case: str, rng) -> dict:
    """The ``p`` mapping of the generated functions for one case: each parameter, each
    leg's copy ``P__N`` and each switch."""
    names = [n for n, _, _ in mod.PARAMETERS]
    p = {n: float(v) for n, v, _ in mod.PARAMETERS}
    if case == "custom":
        p = {n: v * rng.uniform(0.95, 1.05) for n, v in p.items()}
        p.update(p_x=0.01, p_y=-0.02, p_z=0.03)
    for n in names:
        for k in range(1, mod.N_LEGS + 1):
            p[f"{n}__{k}"] = p[n] * (rng.uniform(0.95, 1.05) if case == "custom" else 1.0)
    for s in mod.SWITCHES:
        p[s] = 0.0 if case == "bare" else 1.0
    return p


def reachable(mod, poses, p) -> np.ndarray:
    ik = mod.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
    return (np.abs(ik["sin_q3"]) < 0.95).all(axis=1) & (np.abs(ik["cos_q2"]) < 0.95).all(axis=1)


def pins() -> dict:
    out = {}
    for robot in ROBOTS:
        mod = import_module(f"eigentwist.generated.{robot}_numpy")
        robot_desc = import_module(f"eigentwist.robots.{robot}").describe()
        rng = np.random.default_rng(15)
        cases = {c: inputs(mod, c, rng) for c in ("bare", "on", "custom")}
        box = np.array(robot_desc.workspace)
        pts = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((4 * N_POSES, 3))
        ok = np.ones(len(pts), bool)
        for p in cases.values():
            ok &= reachable(mod, pts, p)
        poses = np.vstack([np.array(robot_desc.x_ref), pts[ok][: N_POSES - 1]])
        out[f"{robot}/poses"] = poses
        for case, p in cases.items():
            out[f"{robot}/{case}/names"] = np.array(list(p))
            out[f"{robot}/{case}/values"] = np.array(list(p.values()))
            ik = mod.inverse_kinematics(poses[:, 0], poses[:, 1], poses[:, 2], p)
            groups = {"inverse_kinematics": ik}
            for g in ("matrices", "jacobians", "gravity"):
                groups[g] = getattr(mod, g)(ik["q"], p)
            for g, res in groups.items():
                for k, v in res.items():
                    shape = mod.OUTPUTS[g][k]
                    out[f"{robot}/{case}/{g}/{k}"] = np.broadcast_to(v, (len(poses),) + tuple(shape))
    return out


if __name__ == "__main__":
    path = Path(__file__).with_name("chain_pin.npz")
    np.savez_compressed(path, **pins())
    print(f"wrote {path}")
