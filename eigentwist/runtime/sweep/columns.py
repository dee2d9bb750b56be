"""The on-disk layout of a sweep, shared by its writers and readers: file names, the
manifest, and the flat one-column-per-mode table of Parquet files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..evaluator import AXES
from .spec import SweepSpec, stiffness_parameter, sweep_evaluator

__all__ = [
    "FORMAT",
    "MANIFEST",
    "LOWEST_FILE",
    "WIDE",
    "manifest",
    "chunk_file",
    "flat_columns",
    "unflat_columns",
    "pyarrow_modules",
    "lowest_path",
]

FORMAT = "eigentwist-sweep"
MANIFEST = "manifest.json"
LOWEST_FILE = "lowest.npz"


def manifest(spec: SweepSpec, complete: bool, backend: str = "", lowest_file: str | None = None) -> dict:
    return {
        "format": FORMAT,
        "version": 1,
        "spec": spec.to_dict(),
        "backend": backend,
        "n_rows": spec.n_rows,
        "n_chunks": spec.n_chunks,
        "n_modes": spec.n_modes,
        "axes": list(AXES),
        "design_names": list(spec.design_names),
        "complete": complete,
        "lowest": lowest_file,
        "units": {
            "pose": "m, rad" if any(c.startswith("rot") for c in pose_columns(spec)) else "m",
            "k_a": _stiffness_unit(spec),
            "freq_hz": "Hz",
            "direction": "index into axes, -1: unreachable",
            "status": "0 reachable, 1 unreachable, 2 serial singular, 3 parallel singular",
            "damped_hz": "Hz (a model with damping only)",
            "damping_ratio": "1 (a model with damping only)",
        },
    }


def _stiffness_unit(spec: SweepSpec) -> str:
    ev = sweep_evaluator(spec.robot, spec.backend)
    return ev.parameter(stiffness_parameter(ev)).unit


def pose_columns(spec: SweepSpec) -> tuple:
    """Table column names of the pose: ``x, y, z``; a 6-DoF robot adds ``rot_x, rot_y, rot_z``
    (rad; ``rx, ry, rz`` stay mode labels)."""
    return tuple(getattr(sweep_evaluator(spec.robot, spec.backend).robot, "pose", ("x", "y", "z")))


def chunk_file(index: int) -> str:
    return f"chunk-{index:06d}.npz"


# (n, modes) arrays as one column per mode; the damped ones only where the model has damping
WIDE = {"freq_hz": "f{}_hz", "direction": "dir{}", "damped_hz": "fd{}_hz", "damping_ratio": "zeta{}"}


def flat_columns(columns: dict, spec: SweepSpec) -> dict:
    """Named 1-D columns for a table: x, y, z, k_a, <varied names>, f1_hz.., dir1.., and the rest."""
    out = {a: columns["pose"][:, k] for k, a in enumerate(pose_columns(spec))}
    out["k_a"] = columns["k_a"]
    out.update({name: columns["design"][:, k] for k, name in enumerate(spec.design_names)})
    for key, val in columns.items():
        if key in ("pose", "k_a", "design"):
            continue
        if np.ndim(val) == 2 and key.endswith("_pose"):  # a pose per row (the lowest table's damped keys)
            out.update({f"{key}_{a}": val[:, k] for k, a in enumerate(pose_columns(spec))})
        elif np.ndim(val) == 2:
            out.update({WIDE[key].format(j + 1): val[:, j] for j in range(val.shape[1])})
        else:
            out[key] = val
    return out


def unflat_columns(table: dict, spec: SweepSpec) -> dict:
    """The inverse of :func:`flat_columns`."""
    n = len(table["k_a"])
    names = pose_columns(spec)
    out = {
        "pose": np.column_stack([table[a] for a in names]),
        "k_a": np.asarray(table["k_a"]),
        "design": np.column_stack([table[n_] for n_ in spec.design_names]) if spec.vary else np.empty((n, 0)),
    }
    used = set(names) | {"k_a"} | set(spec.design_names)
    for key, pattern in WIDE.items():
        names = [pattern.format(j + 1) for j in range(spec.n_modes)]
        if names[0] in table:
            out[key] = np.column_stack([table[c] for c in names])
            used.update(names)
    axes = pose_columns(spec)
    for key in sorted({k[: -len(axes[0]) - 1] for k in table if k.endswith("_pose_" + axes[0])}):
        cols = [f"{key}_{a}" for a in axes]
        out[key] = np.column_stack([table[c] for c in cols])
        used.update(cols)
    out.update({k: np.asarray(v) for k, v in table.items() if k not in used})
    return out


def pyarrow_modules():
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError as exc:
        raise InputError(
            f'Parquet output needs the optional parquet extra: pip install "eigentwist[parquet]" ({exc})'
        ) from None
    return pyarrow, pyarrow.parquet


def lowest_path(path) -> Path:
    """Where the :func:`lowest` table of a Parquet sweep goes: ``OUT.lowest.parquet``."""
    path = Path(path)
    return path.with_name(path.name[: -len(".parquet")] + ".lowest.parquet")
