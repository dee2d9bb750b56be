"""``eigentwist synth ... --uff DIR``: the options and the run of a synthetic modal-test campaign.

Kept beside ``synth`` (which calls :func:`add_uff_options` and :func:`run_uff`); this
module defines no subcommand of its own.
"""

from __future__ import annotations

UFF_EPILOG = """
modal-test campaign (--uff DIR): one UFF file per pose x k_a and DIR/manifest.csv (input of
`eigentwist identify`); FRFs from the truth's M, K with modal damping (--damping) measured in
--layout: triaxial (accelerometer and hammer along +X, +Y, +Z at the sensor), uniaxial (uniaxial
accelerometers 1+X, 2+Y, 3+Z, 4+X, hammer at node 1 along X, Y, Z), roving-hammer (one
accelerometer 1+X, hammer at 1+X, 2+Y, 3+Z, 4+Y, 4+Z) or shaker (one shaker at 1+X, accelerometers
1+X, 1+Y, 2+Y, 3+Z, 4+Z); node 1 is the sensor, nodes 2, 3, 4 at (0.08, 0, 0), (0, 0.08, 0),
(-0.05, -0.05, 0.04) m from it, their positions in UFF dataset 15; --noise is then complex noise
on each FRF value:
  eigentwist synth --truth paper+payload_mass:m_p=0.35 --k-a 250,500,1000,4000 \\
      --pose 0 0 -0.625 --pose 0.06 -0.04 -0.6 --uff campaign/ --damping 1.5% --noise 1% --seed 1
"""


def add_uff_options(p) -> None:
    g = p.add_argument_group("modal-test campaign (UFF)")
    g.add_argument("--uff", metavar="DIR", help="write a campaign (manifest.csv + UFF files) here instead of a CSV")
    g.add_argument("--damping", default="1.5%", help="modal damping ratio of every mode (default: 1.5%%)")
    g.add_argument(
        "--noise-kind",
        default="proportional",
        choices=("proportional", "additive"),
        help="FRF noise relative to each value, or to each FRF's RMS (default: proportional)",
    )
    g.add_argument(
        "--form",
        default="accelerance",
        choices=("accelerance", "mobility", "receptance"),
        help="FRF form written (default: accelerance)",
    )
    g.add_argument(
        "--dataset",
        type=int,
        default=58,
        choices=(58, 55),
        help="58: FRFs (default); 55: the truth's modes as already identified",
    )
    g.add_argument(
        "--sensor",
        nargs=3,
        type=float,
        metavar=("RX", "RY", "RZ"),
        help="sensor offset from the end-effector origin, m (default: the origin)",
    )
    g.add_argument("--node", type=int, default=1, help="UFF node number of the sensor (default: 1)")
    g.add_argument(
        "--layout",
        default="triaxial",
        choices=("triaxial", "uniaxial", "roving-hammer", "shaker"),
        help="where the FRFs are measured (see below; default: triaxial)",
    )


def run_uff(args, ev, k_a, poses) -> int:
    from ..modal.synth import synth_campaign

    path = synth_campaign(
        args.truth,
        k_a,
        poses,
        args.uff,
        ev,
        args.damping,
        args.noise,
        args.seed,
        args.noise_kind,
        args.form,
        args.sensor,
        args.node,
        args.dataset,
        args.layout,
    )
    n = len(k_a) * (len(poses) if poses is not None else 1)
    print(f"wrote {n} UFF files (dataset {args.dataset}) and {path} (truth: {args.truth})")
    return 0
