"""Write a sweep: an ``.npz`` directory (manifest + one file per chunk) or a Parquet file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...outputs import atomic_path, write_atomic
from ..errors import InputError
from .columns import FORMAT, LOWEST_FILE, MANIFEST, chunk_file, flat_columns, lowest_path, manifest, pyarrow_modules
from .engines import SweepSummary
from .spec import SweepSpec, sweep_evaluator

__all__ = ["NpzDirectoryWriter", "ParquetWriter", "open_writer", "OutputExistsError"]


class OutputExistsError(InputError):
    """The output path already holds a sweep and ``overwrite`` was not given."""


class NpzDirectoryWriter:
    """A directory: ``manifest.json``, one ``chunk-NNNNNN.npz`` per chunk, ``lowest.npz``.

    The manifest says ``"complete": false`` until :meth:`close`.
    """

    def __init__(self, path, spec: SweepSpec, overwrite: bool = False):
        self.path, self.spec = Path(path), spec
        if self.path.exists() and not self.path.is_dir():
            raise InputError(
                f"output {str(path)!r} exists and is not a directory: expected a directory for .npz chunks"
            )
        ours = (
            [
                p
                for p in self.path.glob("*")
                if p.name in (MANIFEST, LOWEST_FILE) or (p.name.startswith("chunk-") and p.suffix == ".npz")
            ]
            if self.path.exists()
            else []
        )
        if ours and not overwrite:
            raise OutputExistsError(
                f"output {str(path)!r} already holds a sweep: choose another path or pass overwrite=True"
            )
        for p in ours:
            p.unlink()
        self.path.mkdir(parents=True, exist_ok=True)
        self._manifest(complete=False)

    def _manifest(self, **kwargs) -> None:
        text = json.dumps(manifest(self.spec, **kwargs), indent=1)
        write_atomic(self.path / MANIFEST, text + "\n")

    def write(self, index: int, result: dict) -> None:
        with atomic_path(self.path / chunk_file(index)) as tmp:
            np.savez(tmp, **result)

    def close(self, summary: SweepSummary) -> None:
        with atomic_path(self.path / LOWEST_FILE) as tmp:
            np.savez(tmp, **summary.lowest)
        self._manifest(complete=True, backend=summary.backend, lowest_file=LOWEST_FILE)


class ParquetWriter:
    """One Parquet file, one row group per chunk; the manifest in the schema metadata
    (key ``eigentwist.sweep``); the :func:`lowest` table beside it (:func:`lowest_path`)."""

    def __init__(self, path, spec: SweepSpec, overwrite: bool = False):
        self.pa, self.pq = pyarrow_modules()
        self.path, self.spec, self.writer = Path(path), spec, None
        if self.path.exists() and not overwrite:
            raise OutputExistsError(f"output {str(path)!r} already exists: choose another path or pass overwrite=True")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.manifest = manifest(
            spec,
            complete=True,
            backend=sweep_evaluator(spec.robot, spec.backend).backend,
            lowest_file=lowest_path(self.path).name,
        )

    def _table(self, columns: dict, manifest: dict):
        table = self.pa.table(flat_columns(columns, self.spec))
        return table.replace_schema_metadata({"eigentwist.sweep": json.dumps(manifest)})

    def write(self, index: int, result: dict) -> None:
        table = self._table(result, self.manifest)
        if self.writer is None:
            self.writer = self.pq.ParquetWriter(str(self.path), table.schema)
        self.writer.write_table(table)

    def close(self, summary: SweepSummary) -> None:
        if self.writer is not None:
            self.writer.close()
        with atomic_path(lowest_path(self.path)) as tmp:
            self.pq.write_table(self._table(summary.lowest, {"format": FORMAT + "-lowest"}), str(tmp))


def open_writer(path, spec: SweepSpec, overwrite: bool = False):
    """A Parquet writer for ``*.parquet``, else an ``.npz`` directory writer."""
    if str(path).endswith(".parquet"):
        return ParquetWriter(path, spec, overwrite)
    return NpzDirectoryWriter(path, spec, overwrite)
