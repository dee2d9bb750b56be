"""``eigentwist identify``: a modal-test campaign (manifest + UFF files) -> measurement CSV."""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import CliError, declare_outputs, eprint, format_table, progress

HELP = "identify modes and shapes of a modal-test campaign (UFF 58 FRFs or 55 modes) into a measurement CSV"
EPILOG = """MANIFEST.csv: one setting per row, header on line 1. Columns:
  file                 the setting's UFF file, relative to the manifest's folder:
                       dataset 58 FRFs (identified here) or dataset 55 modes (taken as identified)
  k_a                  commanded actuator stiffness, N m/rad (revolute) or N/m (prismatic)
  x, y, z              end-effector position, m (default: the robot's x_ref)
  nodeN_x, nodeN_y, nodeN_z
                       node N's offset from the end-effector origin, m, platform axes
                       (override the UFF file's dataset 15/2411 node coordinates)
  sensor_x, sensor_y, sensor_z
                       the same for the node --node (at the origin when nothing gives it)
  <param>              any model parameter (SI units), passed through to the rows
A single FILE.uff instead of a manifest: its modes are printed (no measurement CSV).

FRFs: any layout: responses and references at any nodes along +-X, +-Y, +-Z (uniaxial or
triaxial accelerometers, several response nodes, roving hammer or sensor, one shaker);
accelerance, mobility and receptance mixed (ordinate type 12, 11, 8; brought to the
highest form present); abscissa in Hz. Poles: LSCF (sdypy-EMA) on every FRF of a
setting at once, orders 2..60, stable when within 0.5 % in frequency and 10 % in damping
of the previous order; a mode is a column of stable poles over >= 6 orders, refined by an
output-error least-squares fit (no LSCF noise bias). Shapes: LSFD residues factored into
response x reference (rank one over the measured pairs); the side with more DOFs gives
the shape, made real at its dominant phase, unit norm, largest component positive. It is
compared with the model (v + omega x r at each node, projected on each measured direction;
MAC over the measured DOFs) when every node has a position and the DOFs see more than one
motion; otherwise one note says so and frequencies and damping go on. sigma_hz: the
largest of the pole's spread over the stable orders, the fit's standard error and 0.1 %
of the frequency.

Output columns: k_a, mode, freq_hz, sigma_hz, kind, x, y, z, damping_ratio, phi_x, phi_y, phi_z
(freq_hz: each pole's omega_n/2pi, so kind = undamped; damping_ratio: its zeta)
(+ sensor_x, sensor_y, sensor_z when a shape point is off the origin or the manifest gives
positions, + phi_N_x ... and nodeN_x ... for shapes over other DOFs, + its parameter
columns). mode: x, y, z (the largest translation) and phi at a node measured along X, Y and
Z; other layouts: a rank 1, 2, ... and, where they give a shape, phi_N_a = its component at
node N along +a with node N's position nodeN_x, nodeN_y, nodeN_z (MAC over those DOFs).

examples:
  eigentwist synth --truth paper+payload_mass:m_p=0.35 --k-a 250,500,1000,4000 \\
      --pose 0 0 -0.625 --pose 0.06 -0.04 -0.6 --uff campaign/ --damping 1.5% --noise 1% --seed 1
  eigentwist identify campaign/manifest.csv -o identified.csv --plot campaign/plots
  eigentwist compare identified.csv --model paper      # MAC per row
  eigentwist diagnose identified.csv --baseline paper  # payload_mass, m_p = 0.35 kg
  eigentwist identify tests/data/measured_beam/beam_accelerance.uff   # 1 sensor, roving hammer
"""


def add_parser(sub):
    p = sub.add_parser(
        "identify", help=HELP, description=HELP, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("manifest", metavar="MANIFEST.csv", help="campaign manifest (see below) or one FILE.uff")
    p.add_argument("-o", "--output", metavar="MEAS.csv", help="write the measurement CSV here (default: stdout)")
    p.add_argument("--band", metavar="FMIN:FMAX", help="frequency band, Hz (default: the FRFs' axis)")
    p.add_argument(
        "--node", type=int, default=1, help="node of the sensor_* columns and of dataset 55 shapes (default: 1)"
    )
    p.add_argument(
        "--sigma-floor",
        default="0.1%",
        metavar="REL",
        help="smallest sigma_hz relative to the frequency; the sigma of dataset 55 modes (default: 0.1%%)",
    )
    p.add_argument(
        "--plot",
        metavar="DIR",
        help="write per setting a stabilisation diagram and measured vs re-synthesised FRFs (PNG) here",
    )
    p.add_argument("--robot", default="heli4", help="robot description (default: heli4)")
    declare_outputs(p, output="csv", plot="directory")
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


SHOWN = 5  # shape components shown per row (all of them are in the CSV)


def _mode_rows(named_results) -> tuple[list, list]:
    """Table rows (file, mode, f, sigma, zeta, shape, MCF, orders) and the distinct DOF lists."""
    rows, dofs = [], []
    for name, r in named_results:
        for m in sorted(r.modes, key=lambda m: m.freq_hz):
            if m.dofs not in dofs:
                dofs.append(m.dofs)
            shape = " ".join(f"{v:+.2f}" for v in m.shape[:SHOWN]) + (" ..." if len(m.shape) > SHOWN else "")
            rows.append(
                [
                    *name,
                    m.label,
                    f"{m.freq_hz:.4f}",
                    f"{m.sigma_hz:.3g}",
                    f"{100 * m.damping_ratio:.3f}",
                    shape,
                    f"{m.complexity:.2f}",
                    m.orders or "-",
                ]
            )
    return rows, dofs


def _print_modes(named_results, name_headers) -> None:
    rows, dofs = _mode_rows(named_results)
    print(format_table([*name_headers, "mode", "f [Hz]", "sigma [Hz]", "zeta [%]", "shape", "MCF", "orders"], rows))
    for d in dofs:
        print(f"shape over {', '.join(d)}")


def _one_file(args) -> int:
    from ..modal.identify import identify_frfs, modes_from_set
    from ..modal.layout import note_line, shape_note
    from ..modal.uff_io import FrfSet, read_uff

    if args.output:
        raise CliError(
            f"-o {args.output}: a single UFF file has no k_a or pose for a measurement CSV; "
            "list it in a campaign manifest (see --help)"
        )
    data = read_uff(args.manifest, args.node)
    res = identify_frfs(data, parse_band(args.band)) if isinstance(data, FrfSet) else modes_from_set(data)
    _print_modes([((), res)], [])
    why = shape_note(res.modes[0].dofs, data.coords) if isinstance(data, FrfSet) and res.modes else None
    if why:
        eprint(f"note: {note_line(Path(args.manifest).name, why)}")
    if args.plot and res.stabilisation is not None:
        from ..modal.plots import plot_frfs, plot_stabilisation

        Path(args.plot).mkdir(parents=True, exist_ok=True)
        plot_stabilisation(res, Path(args.plot) / f"{Path(args.manifest).stem}_stabilisation.png")
        plot_frfs(res, Path(args.plot) / f"{Path(args.manifest).stem}_frf.png")
    print(
        f"{len(res.modes)} modes in {res.band[0]:g}..{res.band[1]:g} Hz"
        + (f" in {res.seconds:.2f} s" if res.seconds else "")
    )
    return 0


def run(args) -> int:
    from ..outputs import write_atomic
    from .common import guard_outputs, say
    from ..diagnose.evaluators import evaluator
    from ..diagnose.synth import parse_noise
    from ..modal.campaign import identify_campaign, measurement_csv
    from ..robots import NAMES

    if str(args.manifest).lower().endswith((".uff", ".unv")):
        return _one_file(args)
    if args.robot not in NAMES:
        raise CliError(f"--robot {args.robot!r}: expected one of {', '.join(NAMES)}")
    ev = evaluator(args.robot)
    res = identify_campaign(
        args.manifest,
        ev,
        parse_band(args.band),
        args.node,
        parse_noise(args.sigma_floor, "--sigma-floor"),
        progress=progress,
    )
    for note in res.notes:
        eprint(f"note: {note}")
    text = measurement_csv(res.campaign, res.results)
    if args.plot:
        from ..modal.plots import plot_campaign

        plot_campaign(res, args.plot)
    if not args.output:
        print(text, end="")
        return 0
    guard_outputs(args, [s.file for s in res.campaign.settings])  # nor one of the manifest's UFF files
    write_atomic(args.output, text)
    _print_modes(
        [((s.file.name, f"{s.k_a:g}"), r) for s, r in zip(res.campaign.settings, res.results)], ["file", "k_a"]
    )
    secs = [r.seconds for r in res.results if r.seconds]
    timing = f"; {sum(secs) / len(secs):.3f} s per setting" if secs else ""
    say(
        f"wrote {len(res.measurements)} modes of {len(res.results)} settings to {args.output}{timing}"
        + (f"; plots in {args.plot}" if args.plot else "")
    )
    return 0
