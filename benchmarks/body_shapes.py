"""The hexapod's shape form against its declared struts: frequencies and d f/d length.

    PYTHONPATH=. python benchmarks/body_shapes.py   # ~20 s CPU from a fresh cache

Loads ``hexapod`` and ``hexapod.describe(bodies="shapes")`` (generated on first use, timed),
compares their frequencies at home and one tilted pose (models "none" and "paper"), and
checks d f/d l_cyl, d f/d l_pis at home (the sensitivity kernel, timed) against central
differences of the frequencies. Figures: benchmarks/README.md.
"""

from __future__ import annotations

import resource

import numpy as np

import eigentwist
from eigentwist.robots import hexapod


def cpu() -> float:
    """This process's CPU time, s."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ev_m = eigentwist.load("hexapod", backend="numpy")
    t = cpu()
    ev_s = eigentwist.load(hexapod.describe(bodies="shapes"), backend="numpy")
    print(f"load hexapod_shapes: {cpu() - t:.1f} s CPU")
    poses = np.array([[0, 0, 0.80, 0, 0, 0], [0.05, -0.03, 0.75, 0.05, -0.04, 0.1]])
    for model in ("none", "paper"):
        fm, fs = ev_m.frequencies(poses, model), ev_s.frequencies(poses, model)
        worst = np.max(np.abs(fs - fm) / fm)
        print(f"{model}: declared {fm.round(3).tolist()}; shapes' largest relative difference {worst:.2g}")
    t = cpu()
    names = ("l_cyl", "l_pis")
    d = ev_s.sensitivities(poses[:1], wrt=names, model="none")
    print(f"sensitivity kernel: {cpu() - t:.1f} s CPU")
    h = 1e-5
    for j, name in enumerate(names):
        x = ev_s.defaults[name]
        up, down = (ev_s.frequencies(poses[:1], "none", **{name: x + s * h}) for s in (1, -1))
        fd = (up - down)[0] / (2 * h)
        err = np.max(np.abs(fd - d[0, :, j])) / np.max(np.abs(d[0, :, j]))
        print(f"d f/d {name} at home: {d[0, :, j].round(2).tolist()} Hz/m; differences agree to {err:.2g}")


if __name__ == "__main__":
    main()
