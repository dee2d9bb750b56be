"""``eigentwist identify``: a modal-test campaign (manifest + UFF files) -> measurement CSV."""
from __future__ import annotations

import argparse

from .common import CliError, format_table, progress

HELP = "identify modes and mode shapes from a modal-test campaign (UFF 58 FRFs or 55 modes) into a measurement CSV"
EPILOG = """MANIFEST.csv: one setting per row, header on line 1. Columns:
  file                        the setting's UFF file, relative to the manifest's folder:
                              dataset 58 FRFs (identified here) or dataset 55 modes (taken as identified)
  k_a                         commanded actuator stiffness, N m/rad (revolute) or N/m (prismatic)
  x, y, z                     end-effector position, m (default: the robot's x_ref)
  sensor_x, sensor_y, sensor_z  response node's offset from the end-effector origin, m (default 0)
  <param>                     any model parameter (SI units), passed through to the rows

FRFs: responses at --node along +X, +Y, +Z; references at any node along X, Y, Z; the form
(accelerance, mobility, receptance) from the ordinate type of each dataset. Poles: LSCF
(sdypy-EMA), orders 2..60, stable when within 0.5 % in frequency and 10 % in damping of
the previous order; a mode is a column of stable poles over >= 6 orders, refined by an
output-error least-squares fit (no LSCF noise bias). Shapes: LSFD residues, made real at
their dominant phase, unit norm, largest component positive; sigma_hz: the largest of the
pole's spread over the stable orders, the fit's standard error and 0.1 % of the frequency.

Output columns: k_a, mode, freq_hz, sigma_hz, x, y, z, damping_ratio, phi_x, phi_y, phi_z
(+ sensor_x, sensor_y, sensor_z when the manifest has them, + its parameter columns).

examples:
  eigentwist synth --truth paper+payload_mass:m_p=0.35 --k-a 250,500,1000,4000 \\
      --pose 0 0 -0.625 --pose 0.06 -0.04 -0.6 --uff campaign/ --damping 1.5% --noise 1% --seed 1
  eigentwist identify campaign/manifest.csv -o identified.csv --plot campaign/plots
  eigentwist compare identified.csv --model paper      # MAC per row
  eigentwist diagnose identified.csv --baseline paper  # payload_mass, m_p = 0.35 kg
"""


def add_parser(sub):
    p = sub.add_parser("identify", help=HELP, description=HELP, epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("manifest", metavar="MANIFEST.csv", help="campaign manifest (see below)")
    p.add_argument("-o", "--output", metavar="MEAS.csv", help="write the measurement CSV here (default: stdout)")
    p.add_argument("--band", metavar="FMIN:FMAX", help="frequency band, Hz (default: the FRFs' axis)")
    p.add_argument("--node", type=int, default=1, help="response node in the UFF files (default: 1)")
    p.add_argument("--sigma-floor", default="0.1%", metavar="REL",
                   help="smallest sigma_hz relative to the frequency; the sigma of dataset 55 modes (default: 0.1%%)")
    p.add_argument("--plot", metavar="DIR", help="write per setting a stabilisation diagram and measured vs "
                                                  "re-synthesised FRFs (PNG) here")
    p.add_argument("--robot", default="heli4", help="robot description (default: heli4)")
    p.set_defaults(func=run)


def parse_band(text):
    if text is None:
        return None
    lo, sep, hi = text.partition(":")
    try:
        band = (float(lo), float(hi))
    except ValueError:
        raise CliError(f"--band {text!r}: expected FMIN:FMAX in Hz, e.g. 5:60") from None
    if not sep or not 0 <= band[0] < band[1]:
        raise CliError(f"--band {text!r}: expected 0 <= FMIN < FMAX in Hz, e.g. 5:60")
    return band


def run(args) -> int:
    from ..diagnose.evaluators import evaluator
    from ..diagnose.synth import parse_noise
    from ..modal.campaign import identify_campaign, measurement_csv
    from ..robots import NAMES

    if args.robot not in NAMES:
        raise CliError(f"--robot {args.robot!r}: expected one of {', '.join(NAMES)}")
    ev = evaluator(args.robot)
    res = identify_campaign(args.manifest, ev, parse_band(args.band), args.node, parse_noise(args.sigma_floor, "--sigma-floor"),
                            progress=progress)
    text = measurement_csv(res.campaign, res.results)
    if args.plot:
        from ..modal.plots import plot_campaign

        plot_campaign(res, args.plot)
    if not args.output:
        print(text, end="")
        return 0
    with open(args.output, "w") as fh:
        fh.write(text)
    rows = [[s.file.name, f"{s.k_a:g}", m.label, f"{m.freq_hz:.4f}", f"{m.sigma_hz:.3g}", f"{100 * m.damping_ratio:.2f}",
             " ".join(f"{v:+.3f}" for v in m.shape), f"{m.complexity:.3f}", m.orders or "-"]
            for s, r in zip(res.campaign.settings, res.results) for m in sorted(r.modes, key=lambda m: m.freq_hz)]
    print(format_table(["file", "k_a", "mode", "freq [Hz]", "sigma [Hz]", "zeta [%]", "shape x y z",
                        "complexity (MCF)", "stable orders"], rows))
    secs = [r.seconds for r in res.results if r.seconds]
    timing = f"; {sum(secs) / len(secs):.3f} s per setting" if secs else ""
    print(f"wrote {len(res.measurements)} modes of {len(res.results)} settings to {args.output}{timing}"
          + (f"; plots in {args.plot}" if args.plot else ""))
    return 0
