"""``eigentwist matrices``: M, K_R, K_F, frequencies and eigentwists at one pose."""

from __future__ import annotations

import argparse
import json

import numpy as np

from .common import add_model_options, format_table

HELP = "M, K_R, K_F, natural frequencies and eigentwists at one pose"
EPILOG = """examples:
  eigentwist matrices                                 # Heli4 at x_ref = [0, 0, -0.625] m, k_a = 2000 N m/rad
  eigentwist matrices --pose 0.05 0 -0.6 --k-a 1000 --json
  eigentwist matrices --set l2=0.55 --model rigid,payload_mass --set m_p=0.5
  eigentwist matrices --model paper:l2=0.55           # the same as --model paper --set l2=0.55

M, K_R and K_F are the printed model's (its effects switched on). Its natural frequencies
and eigentwists come from those matrices: a rigid model (no structural compliance) from
the 3x3 translational subsets of M and K_R (as the paper does), a flexible one from the
full M and K_F (plus the gravity preload when gravity_preload is on).

JSON keys: robot, model, kind (rigid or flexible), frequencies_from, pose, k_a,
joint_angles_deg (per leg), M, K_R, K_F (6x6), freq_hz and eigentwists (the model's: 3 or 6
modes), freq_rigid_hz (3, from the printed M and K_R, 3x3 translational subsets),
freq_flexible_hz (6, from the printed M and K_F), eigentwists_rigid (3x3),
eigentwists_flexible (6x6), C_F (6x6 exact platform compliance: the legs' rigid constraint
directions with zero compliance instead of K_F's c_rigid penalty; couplings and the preload
included), freq_exact_hz (6, from C_F and M in compliance form: the finite modes ascending,
then null for each rigid-constraint direction, an infinite frequency; freq_hz takes its
finite modes from the same exact condensation),
parameters [{name, value, unit, default, differs, source}]; status (reachable here) and
conditioning (0..1, the inverse condition number of the legs' unit actuation and constraint
wrench rows; a pose at or below 1.49e-06 is parallel singular and refused);
eigentwists are columns, one per mode, scaled so the largest entry is +1. Units: kg, kg m,
kg m^2; N/m, N, N m/rad; Hz.
"""


def add_parser(sub):
    p = sub.add_parser(
        "matrices", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_model_options(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


FROM = {
    "rigid": "M and K_R, 3x3 translational subsets",
    "flexible": "M and K_F, 6x6",
    "condensed": "M and C_F, rigid constraints exact; K_F's c_rigid only for the infinite ones",
}


def reference_line(other: str, label: str, freq_other, freq) -> str:
    """The line on the other model's frequencies from the printed matrices: the same numbers
    as this model's (a 6-DoF robot's legs without constraint wrench: K_F = K_R) are said to be."""
    values = ", ".join(f"{f:.3f}" for f in freq_other)
    if len(freq_other) == len(freq) and np.allclose(freq_other, freq, rtol=1e-9, atol=0, equal_nan=True):
        return (
            f"(the {other} model, from the printed {label}, has the same frequencies here: {values} Hz; "
            "K_F = K_R when no leg has a constraint wrench)"
        )
    return f"(for reference, the {other} model from the printed {label}: {values} Hz)"


def _modes_of(M, K):
    """Frequencies (Hz) and eigentwists of one pose's ``K v = w^2 M v``; NaN where M is not
    positive definite (a point platform's 6x6: its rotations carry no inertia)."""
    from ..runtime.eigen import frequencies_hz, generalized_eigh, normalize_eigentwists

    try:
        lam, V = generalized_eigh(K, M)
    except np.linalg.LinAlgError:
        n = M.shape[-1]
        return np.full(n, np.nan), np.full((n, n), np.nan)
    return frequencies_hz(lam)[0], normalize_eigentwists(V)[0]


def compute(args) -> dict:
    from ..diagnose.values import used_parameters
    from ..runtime import load
    from .common import model_and_values
    from .poses import check_pose, pose_argument

    ev = load(args.robot, backend=args.backend)
    pose = pose_argument(ev, args.pose)
    effects, params = model_and_values(args.model, args.set, ev)
    if args.k_a is not None:
        params["k_a"] = args.k_a
    check_pose(ev, pose, effects, params)
    solved, condensed = ev.constraint_route(effects, **params)  # c_rigid = 0 where no leg direction is rigid
    mats = ev.matrices(pose, effects, **solved)
    q = ev.joint_angles(pose, **params)[0]
    units, per_leg = ev.joint_units, ev.leg_joint_units
    # one pose: an unstable mode (negative stiffness) is an error naming the pose and the mode
    model = ev.modes(pose, effects, unstable="raise", **params)
    B = ev.allowed_twists(pose, **params)  # the rigid model's allowed twists (the 3x3 subsets'
    f_rigid, v_rigid = _modes_of(
        B.swapaxes(1, 2) @ mats["M"] @ B,  # rule; a 3-PRS's turn with the pose)
        B.swapaxes(1, 2) @ mats["K_R"] @ B,
    )
    f_flex, v_flex = _modes_of(mats["M"], mats["K_F"])
    C_F, f_exact = _exact(ev, pose, effects, params)
    kind = ev.stiffness_model(effects)
    # the actuator stiffness's parameter (k_a; a robot of legs that differ names its shared one)
    k_a = "k_a" if "k_a" in ev.defaults else str(ev.robot.actuator_stiffness)
    fixed = getattr(ev.space, "basis", None) is not None
    n = ev.rigid_size()
    rigid_from = (
        "M and K_R, 6x6"
        if fixed and n == 6
        else FROM["rigid"]
        if fixed and ev.pose_names == ("x", "y", "z")
        else f"M and K_R on the allowed twists, {n}x{n}"
    )
    source = (rigid_from if kind == "rigid" else FROM["condensed"] if condensed else FROM[kind]) + (
        " + gravity preload" if "gravity_preload" in effects else ""
    )
    return {
        "robot": ev.robot.name,
        "model": list(effects),
        "model_name": args.model,
        "kind": kind,
        "frequencies_from": source,
        "pose": pose.tolist(),
        "k_a": params.get(k_a, ev.defaults[k_a]),
        "k_a_unit": ev.parameter(k_a).unit,
        "joint_angles_deg": (
            {leg.name: np.degrees(q[i]).tolist() for i, leg in enumerate(ev.robot.legs)}
            if units == ("rad",) * 3
            else None
        ),
        "leg_lengths_m": {leg.name: float(q[i, 0]) for i, leg in enumerate(ev.robot.legs)} if units == ("m",) else None,
        # every leg's joint coordinates in SI (rad; m for a prismatic joint), any robot
        "joint_coordinates": {
            leg.name: q[i, : len(u)].tolist() for i, (leg, u) in enumerate(zip(ev.robot.legs, per_leg))
        },
        "joint_units": list(units),
        "leg_joint_units": {leg.name: list(u) for leg, u in zip(ev.robot.legs, per_leg)},
        "M": mats["M"][0].tolist(),
        "K_R": mats["K_R"][0].tolist(),
        "K_F": mats["K_F"][0].tolist(),
        "freq_hz": model.freq_hz[0].tolist(),
        "axes": list(model.axes),
        "frequencies_rigid_from": rigid_from,
        "eigentwists": model.eigentwists[0].tolist(),
        "freq_rigid_hz": f_rigid.tolist(),
        "freq_flexible_hz": f_flex.tolist(),
        "eigentwists_rigid": v_rigid.tolist(),
        "eigentwists_flexible": v_flex.tolist(),
        "C_F": C_F,
        "freq_exact_hz": f_exact,
        "parameters": used_parameters(ev, effects, params),
        **_status(ev, pose, effects, params),
    }


def _status(ev, pose, effects, params) -> dict:
    """The pose's ``status`` and ``conditioning`` (:meth:`Evaluator.pose_status`)."""
    st = ev.pose_status(pose, effects, **params)
    return {"status": str(st["status"][0]), "conditioning": float(st["conditioning"][0])}


def _exact(ev, pose, effects, params):
    """(C_F, frequencies) of the exact condensation (runtime/condense.py) as JSON lists:
    an infinite frequency (a rigid constraint) is null; (None, None) for a description
    generated without the ``legs`` kernel."""
    from ..runtime.condense import compliance_eigh, platform_compliance

    try:
        C, M = platform_compliance(ev, pose, effects, **params)
    except (ValueError, KeyError, AttributeError):
        return None, None
    try:
        f = compliance_eigh(C, M)[0][0]
    except np.linalg.LinAlgError:  # M not positive definite (a point platform's rotations)
        return C[0].tolist(), None
    return C[0].tolist(), [float(v) if np.isfinite(v) else None for v in f]


def run(args) -> int:
    from .common import say
    from ..diagnose.values import changed_text

    out = compute(args)
    if args.json:
        print(json.dumps(out))
        return 0
    say(
        f"{out['robot']} at pose {out['pose']} {'m, rad' if len(out['pose']) == 6 else 'm'}, "
        f"k_a = {out['k_a']:g} {out['k_a_unit']}, model: "
        f"{out['model_name']} = {', '.join(out['model']) or '(no effect: bare actuator stiffness k_a)'} ({out['kind']})"
    )
    say(changed_text([r for r in out["parameters"] if r["name"] != "k_a"], out["robot"]))
    if out["joint_angles_deg"] is not None:
        say(
            "joint angles (deg): "
            + "; ".join(f"{k}: " + ", ".join(f"{v:.3f}" for v in vals) for k, vals in out["joint_angles_deg"].items())
        )
    elif out["leg_lengths_m"] is not None:
        say("leg lengths (m): " + "; ".join(f"{k}: {v:.6f}" for k, v in out["leg_lengths_m"].items()))
    elif len({tuple(u) for u in out["leg_joint_units"].values()}) == 1:
        say(
            f"joint coordinates ({', '.join(out['joint_units'])}): "
            + "; ".join(f"{k}: " + ", ".join(f"{v:.6f}" for v in vals) for k, vals in out["joint_coordinates"].items())
        )
    else:  # legs that differ: each with its own units
        say(
            "joint coordinates: "
            + "; ".join(
                f"{k} ({', '.join(out['leg_joint_units'][k])}): " + ", ".join(f"{v:.6f}" for v in vals)
                for k, vals in out["joint_coordinates"].items()
            )
        )
    axes = ["rx", "ry", "rz", "x", "y", "z"]
    for key, fmt in (("M", ".6f"), ("K_R", ".2f"), ("K_F", ".2f")):
        say(f"\n{key} (model: {', '.join(out['model']) or 'no effect'}):")
        say(format_table([""] + axes, [[a] + row for a, row in zip(axes, out[key])], fmt))
    n = len(out["freq_hz"])
    say(
        f"\nnatural frequencies of this {out['kind']} model (from {out['frequencies_from']}), Hz: "
        + ", ".join(f"{f:.3f}" for f in out["freq_hz"])
    )
    other = "flexible" if out["kind"] == "rigid" else "rigid"
    label = out["frequencies_rigid_from"] if other == "rigid" else FROM[other]
    say(reference_line(other, label, out[f"freq_{other}_hz"], out["freq_hz"]))
    say(f"\neigentwists of this model (columns; {', '.join(out['axes'])}):")
    say(
        format_table(
            [""] + [f"w{k + 1}" for k in range(n)],
            [[a] + row for a, row in zip(out["axes"], out["eigentwists"])],
            ".3f",
        )
    )
    return 0
