"""``eigentwist matrices``: M, K_R, K_F, frequencies and eigentwists at one pose."""
from __future__ import annotations

import argparse
import json

import numpy as np

from .common import add_model_options, format_table, parse_sets

HELP = "M, K_R, K_F, natural frequencies and eigentwists at one pose"
EPILOG = """examples:
  eigentwist matrices                                 # Heli4 at x_ref = [0, 0, -0.625] m, k_a = 2000 N m/rad
  eigentwist matrices --pose 0.05 0 -0.6 --k-a 1000 --json
  eigentwist matrices --set l2=0.55 --model rigid,payload_mass --set m_p=0.5

JSON keys: pose, k_a, joint_angles_deg (per leg), M, K_R, K_F (6x6), freq_rigid_hz (3),
freq_flexible_hz (6), eigentwists_rigid (3x3), eigentwists_flexible (6x6); eigentwists are
columns, one per mode, scaled so the largest entry is +1. Units: kg, kg m, kg m^2; N/m, N, N m/rad.
"""


def add_parser(sub):
    p = sub.add_parser("matrices", help=HELP, description=HELP, epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_model_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def compute(args) -> dict:
    from ..description.effects import base_name, resolve_model
    from ..runtime import load

    ev = load(args.robot, backend=args.backend)
    pose = np.array(args.pose if args.pose else ev.robot.x_ref, dtype=float)
    params = parse_sets(args.set)
    if args.k_a is not None:
        params["k_a"] = args.k_a
    effects = resolve_model(args.model, ev.robot)
    # the JSON carries both models: the structural effects of the chosen model (or, for a
    # rigid choice, of the robot's "paper" preset) make the flexible one
    is_structural = lambda e: ev.robot.effect(base_name(e)).structural  # noqa: E731
    structural = tuple(e for e in resolve_model("paper", ev.robot) if is_structural(e))
    flex_model = effects if ev.kind(effects) == "flexible" else tuple(effects) + structural
    rigid_model = tuple(e for e in effects if not is_structural(e))
    mats = ev.matrices(pose, effects, **params)
    q = ev.joint_angles(pose, **params)[0]
    # one pose: an unstable mode (negative stiffness) is an error naming the pose and the mode
    rigid = ev.modes(pose, rigid_model, unstable="raise", **params)
    flex = ev.modes(pose, flex_model, unstable="raise", **params)
    return {
        "robot": ev.robot.name,
        "model": list(effects),
        "pose": pose.tolist(),
        "k_a": params.get("k_a", ev.defaults["k_a"]),
        "k_a_unit": ev.parameter("k_a").unit,
        "joint_angles_deg": {leg.name: np.degrees(q[i]).tolist() for i, leg in enumerate(ev.robot.legs)},
        "M": mats["M"][0].tolist(),
        "K_R": mats["K_R"][0].tolist(),
        "K_F": mats["K_F"][0].tolist(),
        "freq_rigid_hz": rigid.freq_hz[0].tolist(),
        "freq_flexible_hz": flex.freq_hz[0].tolist(),
        "eigentwists_rigid": rigid.eigentwists[0].tolist(),
        "eigentwists_flexible": flex.eigentwists[0].tolist(),
    }


def run(args) -> int:
    out = compute(args)
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{out['robot']} at pose {out['pose']} m, k_a = {out['k_a']:g} {out['k_a_unit']}, model: {', '.join(out['model'])}")
    print("joint angles (deg): " + "; ".join(f"{k}: " + ", ".join(f"{v:.3f}" for v in vals)
                                             for k, vals in out["joint_angles_deg"].items()))
    axes = ["rx", "ry", "rz", "x", "y", "z"]
    for key, fmt in (("M", ".6f"), ("K_R", ".2f"), ("K_F", ".2f")):
        print(f"\n{key}:")
        print(format_table([""] + axes, [[a] + row for a, row in zip(axes, out[key])], fmt))
    print("\nnatural frequencies, rigid (K_R, 3x3 translational), Hz: " + ", ".join(f"{f:.3f}" for f in out["freq_rigid_hz"]))
    print("natural frequencies, flexible (K_F), Hz: " + ", ".join(f"{f:.3f}" for f in out["freq_flexible_hz"]))
    print("\neigentwists, flexible (columns):")
    print(format_table([""] + [f"w{k + 1}" for k in range(6)], [[a] + row for a, row in zip(axes, out["eigentwists_flexible"])], ".3f"))
    return 0
