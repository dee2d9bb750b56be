"""Design sweeps: natural frequencies over designs x k_a x workspace poses, in chunks.

One job per module:

* :mod:`.spec` — :func:`make_spec` validates a sweep (:class:`SweepSpec`; its poses :class:`PoseSet`, :mod:`.poseset`);
* :mod:`.evaluate` — :func:`evaluate_chunk` evaluates one chunk (deterministic bits);
* :mod:`.lowest` — :class:`LowestTracker` / :func:`lowest`: per design, the worst-case
  lowest natural frequency over the poses (the number a designer maximises);
* :mod:`.engines` — :func:`run_sweep` runs every chunk in process or on a Dask cluster;
* :mod:`.columns` — the on-disk layout shared by writers and readers;
* :mod:`.writers` — :func:`open_writer` (``.npz`` directory or Parquet file);
* :mod:`.readers` — :func:`load_sweep`, :func:`iter_chunks`.

Pure functions on numbers, no command line: parsing text such as ``l2=0.45:0.60:16`` is
:mod:`eigentwist.cli.sweep_args`'s job.
"""

from .columns import lowest_path
from .engines import ENGINES, SweepSummary, run_sweep
from .evaluate import COLUMNS, DAMPED_COLUMNS, evaluate_chunk, reachable_rows
from .lowest import LowestTracker, lowest
from .readers import SweepData, iter_chunks, load_sweep
from .spec import DEFAULT_CHUNK_SIZE, POSE_BLOCK, PoseSet, SweepSpec, make_spec
from .writers import NpzDirectoryWriter, OutputExistsError, ParquetWriter, open_writer

__all__ = [
    "PoseSet",
    "SweepSpec",
    "SweepSummary",
    "SweepData",
    "LowestTracker",
    "make_spec",
    "reachable_rows",
    "evaluate_chunk",
    "run_sweep",
    "lowest",
    "open_writer",
    "load_sweep",
    "iter_chunks",
    "lowest_path",
    "NpzDirectoryWriter",
    "ParquetWriter",
    "OutputExistsError",
    "ENGINES",
    "COLUMNS",
    "DAMPED_COLUMNS",
    "DEFAULT_CHUNK_SIZE",
    "POSE_BLOCK",
]
