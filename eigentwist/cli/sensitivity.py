"""``eigentwist sensitivity``: which design parameter moves the lowest natural frequency most."""

from __future__ import annotations

import argparse
import json

import numpy as np

from .common import add_jacobian_option, add_model_options, eprint, format_table, parse_sets

HELP = "rank design parameters by their effect on the lowest natural frequency (exact derivatives)"
EPILOG = """examples:
  eigentwist sensitivity                                   # Heli4 at x_ref, paper model, the default list
  eigentwist sensitivity --wrt l2,E_rod,k_a --pose 0.05 0 -0.6
  eigentwist sensitivity --wrt all                         # every parameter of the description
  eigentwist sensitivity --wrt E_rod@2,eta_a@3 --model paper,lower_link_compliance@3
  eigentwist sensitivity --robot delta --model rigid --set l2=0.5 --json

The table ranks parameters by |d ln f1 / d ln p| (the relative sensitivity: the % change of
the lowest frequency per % change of p) and gives d f1 / d p in Hz per SI unit of p.
Default --wrt: k_a and the model's parameters in m, kg and Pa (geometry, masses, moduli;
15 for the Heli4's paper model). NAME@N is leg N's own value of a leg-level parameter.
By default the derivatives come from central differences of the generated matrices M,
K_R, K_F (relative step 1e-5) and the eigenvalue perturbation of Eq. 6 (clusters of repeated
frequencies included): nothing is derived, ~0.01 s for the default list, within ~1e-9 of
the exact derivatives. --jacobian exact uses derivative code generated on first use for
each --wrt list and cached by content hash in $EIGENTWIST_CACHE (default
~/.cache/eigentwist), progress on stderr: ~35 s of generation once for the Heli4's default
list (NumPy backend), then ~1 s per call. A model with gravity_preload has no sensitivities
here (its stiffness is a run-time solve).

JSON keys: robot, model, pose, freq_hz (every mode), parameters: a list sorted by rank with
name, unit, value, dfdp_hz_per_unit (every mode), dlnf1_dlnp; held_fixed (the masses and
inertias, kg, kg m, kg m^2, that stay at their values while a length in --wrt moves: each
derivative holds every other parameter), notes (the lines printed after the table: those
held fixed, and each mass ranked +0 because its body's inertia is a separate parameter).
"""


def add_parser(sub):
    p = sub.add_parser(
        "sensitivity", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_model_options(p)
    p.add_argument(
        "--wrt",
        default=None,
        metavar="NAMES",
        help="comma-separated parameter names, NAME@N for leg N's own value, or 'all' (default: k_a "
        "and the model's parameters in m, kg and Pa: geometry, masses, moduli)",
    )
    add_jacobian_option(
        p,
        "derivatives: central differences of the matrices (default: nothing derived) or the "
        "generated sensitivity kernel (derived and cached on first use per --wrt)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


#: units of the default --wrt: the designer's geometry (m), masses (kg), moduli (Pa) and k_a
DEFAULT_UNITS = ("m", "kg", "Pa")


def default_wrt(ev, effects) -> tuple:
    """The default ``--wrt``: k_a and the parameters in m, kg or Pa that act in the model.

    Parameters of effects outside the model have zero sensitivity; inertias, densities,
    ratios and the stiffnesses of the tuning effects are left to ``--wrt all``.
    """
    from ..description.effects import base_name

    on = {base_name(e) for e in effects}
    return tuple(
        n
        for n, p in ev.parameters.items()
        if (p.effect is None or p.effect in on) and (p.unit in DEFAULT_UNITS or n == "k_a")
    )


def compute(args, progress=None) -> dict:
    from ..description.effects import resolve_model
    from ..runtime import load
    from ..runtime.sensitivity import frequency_sensitivities

    ev = load(args.robot, backend=args.backend)
    pose = np.array(args.pose if args.pose else ev.robot.x_ref, dtype=float)
    params = parse_sets(args.set)
    if args.k_a is not None:
        params["k_a"] = args.k_a
    effects = resolve_model(args.model, ev.robot)
    if args.wrt == "all":
        wrt = list(ev.parameters)
    elif args.wrt:
        wrt = [w.strip() for w in args.wrt.split(",") if w.strip()]
    else:
        wrt = list(default_wrt(ev, effects))
    modes, dfdp = frequency_sensitivities(ev, pose, wrt, effects, params, progress=progress, method=args.jacobian)
    f = modes.freq_hz[0]
    rows = []
    for j, name in enumerate(wrt):
        base = name.partition("@")[0]
        value = float(params.get(name, params.get(base, ev.defaults[base])))
        rows.append(
            dict(
                name=name,
                unit=ev.parameter(name).unit,
                value=value,
                dfdp_hz_per_unit=dfdp[0, :, j].tolist(),
                dlnf1_dlnp=float(dfdp[0, 0, j] * value / f[0]) if f[0] > 0 else float("nan"),
            )
        )
    rows.sort(key=lambda r: -abs(r["dlnf1_dlnp"]) if np.isfinite(r["dlnf1_dlnp"]) else 0.0)
    from ..design.fixed import held_fixed, held_fixed_line, zero_mass_lines

    # each derivative holds every other parameter: the masses in --wrt too, while a length moves
    lengths = [w for w in wrt if ev.parameter(w).unit == "m"]
    notes = [line for line in [held_fixed_line(ev, lengths, effects, params)] if line] + zero_mass_lines(ev, rows)
    return dict(
        robot=ev.robot.name,
        model=list(effects),
        pose=pose.tolist(),
        freq_hz=f.tolist(),
        parameters=rows,
        held_fixed=held_fixed(ev, lengths, effects),
        notes=notes,
    )


def run(args) -> int:
    from .common import say

    out = compute(args, progress=eprint)
    if args.json:
        print(json.dumps(out))
        return 0
    f1 = out["freq_hz"][0]
    say(
        f"{out['robot']} at pose {out['pose']} m, model: {', '.join(out['model'])}; "
        f"lowest natural frequency f1 = {f1:.4g} Hz"
    )
    say("ranked by the relative sensitivity d ln f1 / d ln p (% change of f1 per % change of p):\n")
    table = [
        [
            k + 1,
            r["name"],
            f"{r['value']:.6g}",
            r["unit"],
            f"{r['dlnf1_dlnp']:+.4f}",
            f"{r['dfdp_hz_per_unit'][0]:+.4g}",
            f"Hz/({r['unit']})",
        ]
        for k, r in enumerate(out["parameters"])
    ]
    say(format_table(["rank", "parameter", "value", "unit", "dlnf1/dlnp", "df1/dp", "per"], table))
    for line in out["notes"]:
        say(f"note: {line}")
    return 0
