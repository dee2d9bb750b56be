"""Write ``effects_pin.npz``: every preset and single-effect output of the shipped robots.

The effects-as-data redesign must give every number it gave before. This
script was run once on the code before that redesign (commit eea3e30) and its output is
checked in; ``tests/test_effects_pin.py`` compares today's evaluators with it to 1e-12
relative to each matrix's largest entry. Run it again only to pin a deliberate change:

    python tests/data/make_effects_pin.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import eigentwist

# parameter values away from the defaults where an effect would otherwise hide
# (a payload offset; nothing else is changed so the presets stay the paper's)
PARAMS = {"p_x": 0.01, "p_y": -0.02, "p_z": 0.03}
ROBOTS = ("heli4", "delta")


def models(ev) -> list[str]:
    presets = ["none", "rigid", "paper", "coupled"]
    singles = list(ev.effects)
    on_paper = [f"paper,{e}" for e in ev.effects if e not in ("ee_coupling",)]
    return presets + singles + on_paper


def poses_for(ev) -> np.ndarray:
    rng = np.random.default_rng(11)
    box = np.array(ev.robot.workspace)
    pts = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((5, 3))
    return np.vstack([np.array(ev.robot.x_ref), pts])


def pins() -> dict:
    out = {}
    for robot in ROBOTS:
        ev = eigentwist.load(robot, backend="numpy")
        poses = poses_for(ev)
        out[f"{robot}/poses"] = poses
        for model in models(ev):
            try:
                mats = ev.matrices(poses, model, **PARAMS)
                freq = ev.frequencies(poses, model, **PARAMS)
            except ValueError:
                continue  # an effect this robot lacks (coupled on the Delta)
            for k, v in mats.items():
                out[f"{robot}/{model}/{k}"] = v
            out[f"{robot}/{model}/freq_hz"] = freq
    return out


if __name__ == "__main__":
    path = Path(__file__).with_name("effects_pin.npz")
    np.savez_compressed(path, **pins())
    print(f"wrote {path}")
