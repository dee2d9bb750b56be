"""Read a sweep back: the spec, the manifest, the columns and the lowest-frequency table."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .columns import FORMAT, MANIFEST, chunk_file, lowest_path, pyarrow_modules, unflat_columns
from .evaluate import COLUMNS, DAMPED_COLUMNS
from .spec import SweepSpec

__all__ = ["SweepData", "iter_chunks", "load_sweep"]


@dataclass
class SweepData:
    """A sweep read back by :func:`load_sweep`: the spec, the manifest, the columns
    (as :func:`evaluate_chunk` returns them, all chunks concatenated) and the
    :func:`lowest` arrays (None if the sweep did not finish)."""

    spec: SweepSpec
    manifest: dict
    columns: dict
    lowest: dict | None


def _read_manifest(path: Path) -> dict:
    try:
        manifest = json.loads((path / MANIFEST).read_text())
    except FileNotFoundError:
        raise InputError(
            f"{str(path)!r} holds no {MANIFEST}: expected a directory written by eigentwist sweep"
        ) from None
    if manifest.get("format") != FORMAT:
        raise InputError(f"{str(path / MANIFEST)!r} is not an eigentwist sweep manifest")
    return manifest


def iter_chunks(path):
    """Yield ``(chunk_index, columns)`` of an ``.npz`` sweep directory, one chunk at a time."""
    path = Path(path)
    manifest = _read_manifest(path)
    for index in range(manifest["n_chunks"]):
        file = path / chunk_file(index)
        if not file.exists():
            raise InputError(
                f"{str(file)!r} is missing: the sweep is incomplete ({index} of {manifest['n_chunks']} chunks)"
            )
        with np.load(file) as data:
            yield index, {k: data[k] for k in data.files}


def load_sweep(path) -> SweepData:
    """Read a sweep written by :func:`run_sweep` (``.npz`` directory or ``.parquet``)."""
    path = Path(path)
    if str(path).endswith(".parquet"):
        return _load_parquet(path)
    manifest = _read_manifest(path)
    spec = SweepSpec.from_dict(manifest["spec"])
    parts = [columns for _, columns in iter_chunks(path)]
    keys = COLUMNS + tuple(k for k in DAMPED_COLUMNS if parts and all(k in p for p in parts))
    columns = {k: np.concatenate([p[k] for p in parts]) for k in keys}
    low = None
    if manifest.get("lowest") and (path / manifest["lowest"]).exists():
        with np.load(path / manifest["lowest"]) as data:
            low = {k: data[k] for k in data.files}
    return SweepData(spec, manifest, columns, low)


def _load_parquet(path: Path) -> SweepData:
    _, pq = pyarrow_modules()
    if not path.exists():
        raise InputError(f"{str(path)!r} does not exist: expected a Parquet file written by eigentwist sweep")
    table = pq.read_table(str(path))
    meta = (table.schema.metadata or {}).get(b"eigentwist.sweep")
    if meta is None:
        raise InputError(f"{str(path)!r} is not an eigentwist sweep: no 'eigentwist.sweep' metadata")
    manifest = json.loads(meta)
    spec = SweepSpec.from_dict(manifest["spec"])
    columns = unflat_columns({k: table.column(k).to_numpy() for k in table.column_names}, spec)
    low = None
    if lowest_path(path).exists():
        t = pq.read_table(str(lowest_path(path)))
        low = unflat_columns({k: t.column(k).to_numpy() for k in t.column_names}, spec)
    return SweepData(spec, manifest, columns, low)
