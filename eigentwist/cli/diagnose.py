"""``eigentwist diagnose``: which physical effect is the model missing?"""

from __future__ import annotations

import argparse

from .common import MODEL_SYNTAX, add_jacobian_option, declare_outputs
from .compare import DATA_HELP, add_data_options, evaluator_of, load_data

HELP = "find the physical effect a model is missing from measured frequencies, add it, watch the error fall"
EPILOG = (
    DATA_HELP
    + """

The output opens with the answer (at most 8 lines, 4 more with damping): the verdict, what was
added where with its fitted values, which damping effects the data support (where one was
selected or tested) and the measurement that separates two that fit alike, what the data cannot
tell apart (mirror images at the measured poses as one), outliers and the stated uncertainty,
and the one next measurement. --details adds what it did:
  1. compares the baseline and says where it fails and what the residual pattern suggests;
  2. fits every catalogue effect the baseline lacks (bounded weighted least squares on the
     frequencies), with standard errors, RMS/max error, AICc and an F-test p-value; ranks them;
  3. says which effects these data cannot tell apart and where to measure next to separate them;
  4. adds the best significant, physically plausible effect and repeats (forward selection), naming
     at each step the effects the data cannot tell from the one added, then says whether the final
     model explains the data within the uncertainties (chi-square test) and, if not, why: too few
     rows, the stated uncertainty (Birge ratio), isolated outlying rows (set aside, by CSV line), or
     an effect outside the catalogue. A fit outside a parameter's plausible range is reported
     implausible with the value it would need and never selected.
--add EFFECT replaces step 4 by your own choice (fitted in the order given).
--set NAME=VALUE (or --baseline paper:NAME=VALUE) gives the model's values; a parameter the
diagnosis fits starts from it. A CSV column wins over --set, which wins over the default.

JSON keys: answer {lines, verdict, why, added, apart, rows, next, effects, cannot_tell_apart,
mirror_images}, baseline {effects, rms_pct, max_pct, ...}, ranking [{effect, params, param_std,
rms_pct, max_pct, aicc, p_value, indistinguishable_from, plausible, plausible_range, ...}], selected,
steps [{effects, rms_pct, max_pct, alternatives, ...}], final {effects, rms_pct, max_pct, explained,
alternatives, message, ...}, outliers [{line, k_a, mode, freq_hz, residual_sigma}], uncertainty
{verdict: consistent|understated|overstated|too few rows, birge_ratio}, next_measurement, criteria,
parameters [{name, value, unit, default, differs, source (default, given, data column, fitted), ...}].
Units: SI (params), %.

examples:
  eigentwist diagnose paper                       # the paper's measurements from the rigid model
  eigentwist diagnose paper --details             # the answer, then the ranking, steps and criteria
  eigentwist diagnose data.csv --baseline paper --json
  eigentwist diagnose data.csv --add ee_compliance --plot steps.png
"""
)


def add_parser(sub):
    p = sub.add_parser(
        "diagnose", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_data_options(p)
    p.add_argument("--baseline", default="rigid", help=f"starting model: {MODEL_SYNTAX} (default: rigid)")
    p.add_argument(
        "--add",
        action="append",
        metavar="EFFECT",
        help="add this effect by hand (fitted) instead of the automatic selection; repeatable or comma-separated",
    )
    p.add_argument(
        "--alpha",
        type=float,
        default=None,
        help="significance level of the F test, the goodness of fit and the outlier test (default: 0.01)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="FILE.png", help="write the baseline/final model plot and the error step by step")
    p.add_argument(
        "--details",
        action="store_true",
        help="after the answer, print the full diagnosis: ranking, residual patterns, selection steps, criteria",
    )
    p.add_argument(
        "--rows",
        action="store_true",
        help="also print the per-row tables of the baseline and final model (implies --details)",
    )
    add_jacobian_option(
        p,
        "the fits' Jacobian: central differences in the residuals' evaluator call (default: measured "
        "faster, benchmarks/README.md) or exact, from generated design sensitivities (derived and "
        "compiled once per cache)",
    )
    declare_outputs(p, plot="image")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..diagnose.fit import using_jacobian
    from ..diagnose.answer import answer_text
    from ..diagnose.values import changed_text
    from ..diagnose.verdict import diagnosis_text
    from ..diagnose.select import diagnose
    from ..diagnose.stats import ALPHA
    from .common import CliError, model_and_values, progress, say

    alpha = ALPHA if args.alpha is None else args.alpha
    if not 0 < alpha < 1:
        raise CliError(f"--alpha {alpha!r}: expected a probability in (0, 1)")
    effects, values = model_and_values(args.baseline, args.set, evaluator_of(args), "--baseline")
    ev, meas = load_data(args, values)
    add = None if not args.add else [e for item in args.add for e in item.split(",") if e.strip()]
    with using_jacobian(args.jacobian):
        d = diagnose(meas, effects, ev=ev, add=add, alpha=alpha, progress=progress, values=values)
    if args.plot:
        from ..diagnose.plots import plot_diagnosis

        plot_diagnosis(d, args.plot, ev)
    if args.json:
        print(d.json())
        return 0
    print(answer_text(d, ev))
    given = [r for r in d.parameters if r["source"] != "fitted"]
    if any(r["differs"] for r in given) and not (args.details or args.rows):
        say(changed_text(given, d.robot))  # the values used, when not the robot's defaults
    if args.details or args.rows:
        say("\n" + diagnosis_text(d, ev, show_rows=args.rows))
    else:
        print("\n(--details: the ranking of every candidate, residual patterns, criteria; --json: all of it)")
    if args.plot:
        print(f"\nplot: {args.plot}")
    return 0
