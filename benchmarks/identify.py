"""Time of ``eigentwist identify`` on measured and synthetic FRFs.

    .venv/bin/python benchmarks/identify.py

Times, best of 3, wall and CPU (one BLAS thread, as ``identify`` runs):

* the public measured set (``tests/data/measured_beam/beam_accelerance.uff``: one
  accelerometer, hammer at three points, 1001 lines, six modes in 1..990 Hz);
* one setting of each synthetic layout (triaxial, uniaxial, roving-hammer, shaker) of
  ``eigentwist synth --uff`` (the paper's Heli4 with a 0.35 kg payload, 1 % noise).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from eigentwist.diagnose.evaluators import evaluator  # noqa: E402
from eigentwist.modal import identify_frfs, read_uff, synth_campaign  # noqa: E402


def best(fn, repeat: int = 3) -> tuple[float, float, object]:
    """(wall s, CPU s, result) of the fastest of ``repeat`` calls."""
    runs = []
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        out = fn()
        runs.append((time.perf_counter() - w, time.process_time() - c, out))
    return min(runs, key=lambda r: r[0])


def main() -> None:
    frfs = read_uff(ROOT / "tests" / "data" / "measured_beam" / "beam_accelerance.uff")
    wall, cpu, res = best(lambda: identify_frfs(frfs))
    modes = sorted(res.modes, key=lambda m: m.freq_hz)
    print(
        f"measured beam ({frfs.H.shape[0]} lines, {frfs.H.shape[1]} FRFs): {len(modes)} modes, "
        f"wall {wall:.2f} s, CPU {cpu:.2f} s"
    )
    for m in modes:
        print(
            f"  {m.freq_hz:9.3f} Hz  zeta {100 * m.damping_ratio:.3f} %  sigma {m.sigma_hz:.3g} Hz  "
            f"({m.orders} stable orders)"
        )
    ev = evaluator("heli4")
    with tempfile.TemporaryDirectory() as tmp:
        for layout in ("triaxial", "uniaxial", "roving-hammer", "shaker"):
            manifest = synth_campaign(
                "paper+payload_mass:m_p=0.35",
                [1000.0],
                [[0.06, -0.04, -0.6]],
                Path(tmp) / layout,
                ev,
                noise="1%",
                seed=1,
                layout=layout,
            )
            one = read_uff(manifest.parent / "setting_01.uff")
            wall, cpu, res = best(lambda: identify_frfs(one))
            print(
                f"{layout:>13}: {one.H.shape[1]:2d} FRFs x {one.H.shape[0]} lines, {len(res.modes)} modes, "
                f"wall {wall:.2f} s, CPU {cpu:.2f} s"
            )


if __name__ == "__main__":
    main()
