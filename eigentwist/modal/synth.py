"""Synthetic modal-test campaigns: a truth model's FRFs (or modes) as UFF files and a manifest.

Per setting (every pose x k_a) the truth's M and K (6x6 flexible or 3x3 rigid) give the
FRFs of :mod:`.frf`: responses at the sensor along +X, +Y, +Z, hammer forces at the same
point along +X, +Y, +Z, modal damping ratio ``damping`` for every mode. Complex noise
(seeded) is either *proportional*, ``H (1 + noise (n1 + i n2) / sqrt(2))``, or
*additive*, ``H + noise rms(|H_ij|) (n1 + i n2) / sqrt(2)`` per FRF, with n1, n2 ~ N(0, 1).

The frequency axis of a setting runs from 0 to twice its highest mode along x, y
or z, with a step that puts at least 8 lines in the half-power bandwidth 2 zeta f of
its lowest mode (1, 2 or 5 times a power of ten, so that UFF's 6-digit abscissa holds it
exactly).

The ``layout`` (:data:`LAYOUTS`) says where the FRFs are measured: ``triaxial`` (a
triaxial accelerometer at the sensor, hammer along +X, +Y, +Z there), ``uniaxial``
(uniaxial accelerometers at four nodes, 1+X, 2+Y, 3+Z, 4+X, hammer at node 1 along X,
Y, Z), ``roving-hammer`` (one accelerometer 1+X, the hammer roving over five DOFs at
four nodes) or ``shaker`` (one shaker at 1+X, uniaxial accelerometers at five DOFs
1+X, 1+Y, 2+Y, 3+Z, 4+Z).
Node 1 is the sensor; nodes 2, 3, 4 sit at ``NODE_OFFSETS`` (m) from it; every layout
but ``triaxial`` writes the node positions as UFF dataset 15 in each file.

With ``dataset=55`` the files hold the truth's modes along x, y, z instead (frequency
``f (1 + noise N(0, 1))``, the damping ratio, the shape at the sensor plus ``noise``
N(0, 1) per component), as a modal-test system exports identified modes.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..diagnose.shapes import sensor_shapes
from ..diagnose.synth import parse_noise, parse_truth
from ..runtime.eigen import generalized_eigh
from .campaign import SENSOR, write_manifest
from .frf import frf_from_modes
from .layout import model_shapes, projection
from .uff_io import FrfSet, write_frf_uff, write_modes_uff

__all__ = ["synth_campaign", "frequency_axis", "add_noise", "NOISE_KINDS", "LAYOUTS", "NODE_OFFSETS"]

#: layout -> (response DOFs, reference DOFs), labels "NODE+AXIS" (module doc)
LAYOUTS = {
    "triaxial": (("1+X", "1+Y", "1+Z"), ("1+X", "1+Y", "1+Z")),
    "uniaxial": (("1+X", "2+Y", "3+Z", "4+X"), ("1+X", "1+Y", "1+Z")),
    "roving-hammer": (("1+X",), ("1+X", "2+Y", "3+Z", "4+Y", "4+Z")),
    "shaker": (("1+X", "1+Y", "2+Y", "3+Z", "4+Z"), ("1+X",)),
}
#: offsets of nodes 2, 3, 4 from node 1 (the sensor), m
NODE_OFFSETS = {2: (0.08, 0.0, 0.0), 3: (0.0, 0.08, 0.0), 4: (-0.05, -0.05, 0.04)}

NOISE_KINDS = ("proportional", "additive")
SPAN = 2.0
LINES_PER_BANDWIDTH = 8


def frequency_axis(f_low: float, f_high: float, zeta: float) -> np.ndarray:
    """0 ... SPAN * f_high Hz with a 1/2/5 x 10^k step, >= 8 lines per 2 zeta f_low."""
    target = 2 * zeta * f_low / LINES_PER_BANDWIDTH
    decade = 10.0 ** np.floor(np.log10(target))
    step = max(m * decade for m in (1, 2, 5) if m * decade <= target)
    n = int(np.ceil(SPAN * f_high / step))
    return np.round(np.arange(n + 1) * step, 10)


def add_noise(H: np.ndarray, noise: float, rng, kind: str = "proportional") -> np.ndarray:
    """Complex Gaussian noise on FRFs H (F, 3, R) (module doc)."""
    if kind not in NOISE_KINDS:
        raise InputError(f"noise kind {kind!r}: expected one of {', '.join(NOISE_KINDS)}")
    n = (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)) / np.sqrt(2)
    if kind == "proportional":
        return H * (1 + noise * n)
    rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=0, keepdims=True))
    return H + noise * rms * n


def _modes_at(M, K, sensor):
    lam, V = generalized_eigh(K[None], M[None])
    omega = np.sqrt(np.clip(lam[0], 0.0, None))
    U = sensor_shapes(V, sensor)[0]  # (3, n), mass-normalised
    directions = np.argmax(np.abs(V[0] / np.abs(V[0]).max(axis=0)), axis=0) + (3 if V.shape[1] == 3 else 0)
    return omega, U, directions


def _layout_frfs(layout, freq, omega, M, K, r, zeta, form, rel, rng, noise_kind, node) -> FrfSet:
    """The noisy FRFs of one setting measured in ``layout`` (node 1 renumbered ``node``)."""
    responses, references = LAYOUTS[layout]
    coords = {1: r, **{n: r + np.asarray(d) for n, d in NODE_OFFSETS.items()}}
    V = generalized_eigh(K[None], M[None])[1][0]
    U_o, U_r = (model_shapes(V, projection(dofs, coords)) for dofs in (responses, references))
    H = add_noise(frf_from_modes(freq, omega, U_o, zeta, form, U_r), rel, rng, noise_kind)
    rename = {1: node, **{n: n + (node == n) * 10 for n in NODE_OFFSETS}}  # keep node numbers distinct
    relabel = [[f"{rename[int(d.split('+')[0])]}+{d.split('+')[1]}" for d in dofs] for dofs in (responses, references)]
    positions = {} if layout == "triaxial" else {rename[n]: c for n, c in coords.items()}
    return FrfSet.from_grid(freq, H, *relabel, form, coords=positions)


def synth_campaign(
    truth: str,
    k_a,
    poses,
    out_dir,
    ev,
    damping=0.015,
    noise=0.01,
    seed: int = 0,
    noise_kind: str = "proportional",
    form: str = "accelerance",
    sensor=None,
    node: int = 1,
    dataset: int = 58,
    layout: str = "triaxial",
) -> Path:
    """Write one UFF file per (pose, k_a) and ``manifest.csv`` into ``out_dir``; return the manifest path.

    Parameters
    ----------
    truth : ``PRESET[+EFFECT:PARAM=VALUE,...]`` (:func:`eigentwist.diagnose.synth.parse_truth`).
    k_a : N m/rad; poses : (P, 3) m (None: x_ref).
    damping : modal damping ratio (0.015 or ``"1.5%"``); noise : relative (``"1%"``).
    sensor : (3,) sensor offset from the end-effector origin, m (None: the origin; the
        manifest then has no sensor columns).
    dataset : 58 (FRFs) or 55 (modes).
    layout : where the FRFs are measured (:data:`LAYOUTS`; dataset 58 only).
    """
    t = parse_truth(truth, ev)
    zeta, rel = parse_noise(damping, "damping"), parse_noise(noise)
    if not zeta > 0:
        raise InputError(f"damping {damping!r}: expected a ratio > 0, e.g. 1.5%")
    if dataset not in (55, 58):
        raise InputError(f"dataset {dataset!r}: expected 58 (FRFs) or 55 (modes)")
    if layout not in LAYOUTS:
        raise InputError(f"layout {layout!r}: expected one of {', '.join(LAYOUTS)}")
    poses = np.atleast_2d(np.asarray(ev.robot.x_ref if poses is None else poses, dtype=float))
    k_a = np.atleast_1d(np.asarray(k_a, dtype=float))
    settings = list(itertools.product(range(len(poses)), range(len(k_a))))
    M, K = ev.stiffness(poses[[s[0] for s in settings]], t.effects, k_a=k_a[[s[1] for s in settings]], **t.values)
    r = np.zeros(3) if sensor is None else np.asarray(sensor, dtype=float)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    rows = []
    for j, (p, k) in enumerate(settings):
        omega, U, directions = _modes_at(M[j], K[j], r)
        f_k = omega / (2 * np.pi)
        seen = directions >= 3  # modes along x, y, z
        name = f"setting_{j + 1:02d}.uff"
        if dataset == 58:
            freq = frequency_axis(f_k[seen].min(), f_k[seen].max(), zeta)
            write_frf_uff(
                out / name, _layout_frfs(layout, freq, omega, M[j], K[j], r, zeta, form, rel, rng, noise_kind, node)
            )
        else:
            f_meas = f_k[seen] * (1 + rel * rng.standard_normal(int(seen.sum())))
            shapes = U[:, seen].T / np.linalg.norm(U[:, seen], axis=0)[:, None]
            shapes = shapes + rel * rng.standard_normal(shapes.shape)
            write_modes_uff(out / name, f_meas, np.full(len(f_meas), zeta), shapes, node)
        row = {"file": name, "k_a": k_a[k], "x": poses[p, 0], "y": poses[p, 1], "z": poses[p, 2]}
        if sensor is not None:
            row.update(zip(SENSOR, r))
        rows.append(row)
    return write_manifest(out / "manifest.csv", rows)
