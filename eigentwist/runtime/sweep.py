"""Design sweeps: natural frequencies over designs x k_a x workspace poses, in chunks.

A sweep is the Cartesian product of

* **designs**: every combination of the varied design parameters
  (``vary=(("l2", (0.45, ..., 0.60)), ...)``, SI units), the first one slowest;
* **k_a**: commanded actuator stiffness values (N m/rad);
* **poses**: end-effector positions (m) in a workspace box, a regular grid or a seeded
  uniform random sample, the fastest index.

Row ``i`` of the product is ``pose_index = i % n_poses`` and ``case = i // n_poses``
with ``case = design_index * n_k_a + k_a_index``. A chunk is a block of consecutive
rows, built from its row numbers by index arithmetic only: the product is never
materialised, so memory is bounded by the chunk size whatever the sweep size.

Pure functions, no command line: :func:`make_spec` (validated spec),
:func:`evaluate_chunk` (one chunk), :func:`run_sweep` (every chunk, in process or on a
Dask cluster, streamed into a writer and the :class:`LowestTracker`),
:func:`open_writer` / :func:`load_sweep` (``.npz`` directory or Parquet file) and
:func:`lowest` (per design, the worst-case lowest natural frequency over the poses:
the number a designer maximises).
"""
from __future__ import annotations

import json
import math
import os
import time
from collections import deque
from contextlib import ExitStack
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import InputError
from .evaluator import AXES, Evaluator

__all__ = ["PoseSet", "SweepSpec", "SweepSummary", "SweepData", "LowestTracker", "make_spec", "parse_values",
           "parse_vary", "reachable_rows", "evaluate_chunk", "run_sweep", "lowest", "open_writer", "load_sweep",
           "iter_chunks", "lowest_path", "ENGINES", "COLUMNS", "DEFAULT_CHUNK_SIZE"]

ENGINES = ("inprocess", "dask")
DEFAULT_CHUNK_SIZE = 65536   # rows per chunk: about 170 MB above the interpreter (NumPy backend)
POSE_BLOCK = 65536           # random poses are drawn in seeded blocks of this many
FORMAT = "eigentwist-sweep"
MANIFEST = "manifest.json"
LOWEST_FILE = "lowest.npz"
COLUMNS = ("pose", "k_a", "design", "freq_hz", "direction", "reachable", "pose_index", "case")


# ------------------------------------------------------------------- spec parsing
def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{what}: {text.strip()!r} is not a finite number")
    return value


def parse_values(text: str, what: str = "values") -> tuple[float, ...]:
    """``"500,1000,2000"`` (a list), ``"500:4000:8"`` (8 values, linspace, ends
    included) or ``"2000"`` (one value) -> a tuple of floats.

    ``what`` names the option in the error, e.g. ``"--k-a '500:x:8'"``.
    """
    text = str(text).strip()
    if not text:
        raise InputError(f"{what}: empty: expected a value, a list A,B,C or a range LO:HI:N")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError(f"{what}: {text!r} is not a range: expected LO:HI:N, e.g. 0.45:0.60:16")
        lo, hi = (_number(p, what) for p in parts[:2])
        try:
            n = int(parts[2])
        except ValueError:
            raise InputError(f"{what}: count {parts[2]!r} in {text!r} is not an integer: expected LO:HI:N with N >= 1") from None
        if n < 1:
            raise InputError(f"{what}: count {n} in {text!r}: expected N >= 1")
        return tuple(float(v) for v in np.linspace(lo, hi, n))
    return tuple(_number(p, what) for p in text.split(","))


def parse_vary(item: str) -> tuple[str, tuple[float, ...]]:
    """``"l2=0.45:0.60:16"`` -> ``("l2", (0.45, 0.46, ..., 0.60))`` (SI units)."""
    name, sep, values = str(item).partition("=")
    if not sep or not name.strip():
        raise InputError(f"--vary {item!r}: expected NAME=LO:HI:N or NAME=A,B,C, e.g. l2=0.45:0.60:16")
    return name.strip(), parse_values(values, f"--vary {item!r}")


# ----------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class PoseSet:
    """End-effector positions in a box ``((xlo, xhi), (ylo, yhi), (zlo, zhi))`` (m).

    ``kind="grid"``: ``shape = (nx, ny, nz)`` points per axis, ends included (an axis
    with one point sits at the middle of its interval), x slowest, z fastest.
    ``kind="random"``: ``n`` uniform samples, reproducible from ``seed`` and
    independent of the chunk size (drawn in blocks of :data:`POSE_BLOCK`).
    """

    kind: str
    box: tuple
    shape: tuple = ()
    n: int = 0
    seed: int = 0

    @property
    def count(self) -> int:
        return int(np.prod(self.shape)) if self.kind == "grid" else int(self.n)

    def axis(self, k: int) -> np.ndarray:
        """Grid coordinates (m) along axis ``k`` (0: x, 1: y, 2: z)."""
        lo, hi = self.box[k]
        return np.array([0.5 * (lo + hi)]) if self.shape[k] == 1 else np.linspace(lo, hi, self.shape[k])

    def take(self, index: np.ndarray) -> np.ndarray:
        """Positions (m), shape (len(index), 3), of the poses numbered ``index``."""
        index = np.asarray(index, dtype=np.int64)
        if self.kind == "grid":
            ijk = np.unravel_index(index, self.shape)
            return np.column_stack([self.axis(k)[ijk[k]] for k in range(3)])
        lo = np.array([b[0] for b in self.box])
        hi = np.array([b[1] for b in self.box])
        block, row = np.divmod(index, POSE_BLOCK)
        unit = np.empty((len(index), 3))
        for b in np.unique(block):
            here = block == b
            unit[here] = _random_block(self.seed, int(b))[row[here]]
        return lo + (hi - lo) * unit


@lru_cache(maxsize=4)
def _random_block(seed: int, block: int) -> np.ndarray:
    """Uniform [0, 1) samples, (POSE_BLOCK, 3), of block ``block`` of stream ``seed``."""
    out = np.random.default_rng([seed, block]).random((POSE_BLOCK, 3))
    out.flags.writeable = False
    return out


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: build it with :func:`make_spec`.

    robot, backend : as :func:`eigentwist.load`; model : preset or effects (as
        ``Evaluator.frequencies``).
    poses : :class:`PoseSet`.
    k_a : commanded actuator stiffness values, N m/rad.
    vary : ``((name, values), ...)`` design parameters varied (SI units), first slowest.
    fixed : ``((name, value), ...)`` parameters set for every row (SI units).
    chunk_size : rows per chunk.
    """

    robot: str
    backend: str
    model: str
    poses: PoseSet
    k_a: tuple
    vary: tuple = ()
    fixed: tuple = ()
    chunk_size: int = DEFAULT_CHUNK_SIZE

    # ----------------------------------------------------------------- sizes
    @property
    def design_names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.vary)

    @property
    def design_shape(self) -> tuple[int, ...]:
        return tuple(len(values) for _, values in self.vary)

    @property
    def n_poses(self) -> int:
        return self.poses.count

    @property
    def n_designs(self) -> int:
        return int(np.prod(self.design_shape, dtype=np.int64))

    @property
    def n_cases(self) -> int:
        """Designs x k_a values: the rows of the :func:`lowest` summary."""
        return self.n_designs * len(self.k_a)

    @property
    def n_rows(self) -> int:
        return self.n_cases * self.n_poses

    @property
    def n_chunks(self) -> int:
        return -(-self.n_rows // self.chunk_size)

    @property
    def n_modes(self) -> int:
        """3 for a rigid model (translational subset), 6 for a flexible one."""
        return 3 if _evaluator(self.robot, self.backend).kind(self.model) == "rigid" else 6

    # ------------------------------------------------------------ arithmetic
    def chunk_rows(self, chunk: int) -> range:
        """Row numbers of chunk ``chunk`` (0-based)."""
        if not 0 <= chunk < self.n_chunks:
            raise InputError(f"chunk {chunk} is out of range: expected 0 to {self.n_chunks - 1}")
        start = chunk * self.chunk_size
        return range(start, min(self.n_rows, start + self.chunk_size))

    def case_values(self, case: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(k_a (n,), design (n, len(vary)))`` of the cases numbered ``case``."""
        case = np.asarray(case, dtype=np.int64)
        design_index, ka_index = np.divmod(case, len(self.k_a))
        k_a = np.asarray(self.k_a, dtype=float)[ka_index]
        if not self.vary:
            return k_a, np.empty((len(case), 0))
        idx = np.unravel_index(design_index, self.design_shape)
        design = np.column_stack([np.asarray(values, dtype=float)[i] for (_, values), i in zip(self.vary, idx)])
        return k_a, design

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict:
        poses = {"kind": self.poses.kind, "box": [list(b) for b in self.poses.box]}
        poses.update({"shape": list(self.poses.shape)} if self.poses.kind == "grid"
                     else {"n": self.poses.n, "seed": self.poses.seed})
        return {"robot": self.robot, "backend": self.backend, "model": self.model, "poses": poses,
                "k_a": list(self.k_a), "vary": {name: list(v) for name, v in self.vary},
                "fixed": dict(self.fixed), "chunk_size": self.chunk_size}

    @classmethod
    def from_dict(cls, d: dict) -> "SweepSpec":
        p = d["poses"]
        poses = PoseSet(p["kind"], tuple(tuple(b) for b in p["box"]), tuple(p.get("shape", ())),
                        int(p.get("n", 0)), int(p.get("seed", 0)))
        return cls(d["robot"], d["backend"], d["model"], poses, tuple(d["k_a"]),
                   tuple((k, tuple(v)) for k, v in d["vary"].items()), tuple(d["fixed"].items()),
                   int(d["chunk_size"]))


@lru_cache(maxsize=None)
def _evaluator(robot: str, backend: str) -> Evaluator:
    """One evaluator per process (a Dask worker loads its own)."""
    from .loader import load

    return load(robot, backend=backend)


def _box(box, robot) -> tuple:
    if box is None:
        return tuple(tuple(float(v) for v in b) for b in robot.workspace)
    flat = np.asarray(box, dtype=float).reshape(-1)
    if flat.shape != (6,) or not np.isfinite(flat).all():
        raise InputError(f"box {np.asarray(box).tolist()}: expected six finite numbers XLO XHI YLO YHI ZLO ZHI in m")
    pairs = tuple((float(flat[2 * k]), float(flat[2 * k + 1])) for k in range(3))
    for name, (lo, hi) in zip("xyz", pairs):
        if lo > hi:
            raise InputError(f"box {name} range [{lo:g}, {hi:g}] m: expected LO <= HI")
    return pairs


def _pose_set(grid, random, seed, box) -> PoseSet:
    if grid is not None and random is not None:
        raise InputError("poses: give a grid or a random sample, not both")
    if random is not None:
        if int(random) != random or random < 1:
            raise InputError(f"random sample size {random!r}: expected an integer >= 1")
        if int(seed) != seed or seed < 0:
            raise InputError(f"seed {seed!r}: expected an integer >= 0")
        return PoseSet("random", box, n=int(random), seed=int(seed))
    shape = tuple(grid) if grid is not None else (5, 5, 5)
    if len(shape) != 3 or any(int(s) != s or s < 1 for s in shape):
        raise InputError(f"grid {list(shape)}: expected three integers NX NY NZ >= 1")
    return PoseSet("grid", box, shape=tuple(int(s) for s in shape))


def _check_parameter(ev: Evaluator, name: str, values, what: str) -> None:
    if name not in ev.parameters:
        raise InputError(f"{what}: unknown parameter {name!r} for {ev.robot.name}: "
                         f"expected names from {', '.join(ev.parameters)}")
    p = ev.parameters[name]
    for value in np.atleast_1d(np.asarray(values, dtype=float)).tolist():
        try:
            p.check(value)
        except ValueError as exc:
            expected = str(exc).partition(": expected ")[2] or "a value within the parameter's bounds"
            raise InputError(f"{what}: parameter {name!r} = {value!r} {p.unit}: expected {expected}") from None


def make_spec(robot: str = "heli4", *, model: str = "paper", backend: str = "numpy", grid=None,
              random=None, seed: int = 0, box=None, k_a=None, vary=(), fixed=None,
              chunk_size: int = DEFAULT_CHUNK_SIZE) -> SweepSpec:
    """Validate a sweep against the robot's description and return its :class:`SweepSpec`.

    grid : (nx, ny, nz) poses per axis (default (5, 5, 5) when ``random`` is None);
    random, seed : a uniform sample of ``random`` poses, reproducible from ``seed``;
    box : six numbers XLO XHI YLO YHI ZLO ZHI (m), default the robot's workspace;
    k_a : values in N m/rad (a sequence or text for :func:`parse_values`), default
        the description's; vary : ``{name: values}`` or ``[(name, values)]`` or
        ``["l2=0.45:0.60:16"]``; fixed : ``{name: value}`` for every row.

    Every name, bound and option is checked here, so that a sweep fails before its
    first chunk; errors name the value and what was expected.
    """
    from ..description.effects import resolve_model

    ev = _evaluator(robot, backend)
    try:
        resolve_model(model, ev.robot)
    except ValueError as exc:
        raise InputError(f"model {model!r}: {exc}") from None
    poses = _pose_set(grid, random, seed, _box(box, ev.robot))
    if "k_a" not in ev.parameters:
        raise InputError(f"robot {robot!r} has no parameter 'k_a': a sweep needs the actuator stiffness")
    k_a = (ev.defaults["k_a"],) if k_a is None else (parse_values(k_a, f"--k-a {k_a!r}") if isinstance(k_a, str)
                                                     else tuple(float(v) for v in np.atleast_1d(k_a)))
    _check_parameter(ev, "k_a", k_a, "k_a")
    pairs = tuple(_vary_pairs(vary))
    fixed = tuple((str(k), float(v)) for k, v in dict(fixed or {}).items())
    names = [n for n, _ in pairs]
    for name, values in pairs:
        if name == "k_a":
            raise InputError("--vary k_a: k_a has its own option: use k_a=... (--k-a 500:4000:8)")
        if names.count(name) > 1:
            raise InputError(f"--vary {name}: given more than once")
        if name in dict(fixed):
            raise InputError(f"{name}: both varied and fixed: give it once")
        _check_parameter(ev, name, values, f"--vary {name}")
    for name, value in fixed:
        if name == "k_a":
            raise InputError("--set k_a: k_a has its own option: use k_a=... (--k-a 2000)")
        _check_parameter(ev, name, value, f"--set {name}={value:g}")
    if int(chunk_size) != chunk_size or chunk_size < 1:
        raise InputError(f"chunk size {chunk_size!r}: expected an integer number of rows >= 1")
    return SweepSpec(robot, backend, model, poses, k_a, pairs, fixed, int(chunk_size))


def _vary_pairs(vary):
    items = vary.items() if isinstance(vary, dict) else vary
    for item in items:
        if isinstance(item, str):
            yield parse_vary(item)
        else:
            name, values = item
            values = parse_values(values, f"--vary {name}={values}") if isinstance(values, str) else values
            yield str(name), tuple(float(v) for v in np.atleast_1d(values))


# ------------------------------------------------------------------- evaluation
def reachable_rows(ev: Evaluator, poses: np.ndarray, params: dict, model) -> np.ndarray:
    """(N,) bool: the poses that :meth:`Evaluator.modes` accepts (reachable, not singular)."""
    return ev.valid(poses, model, **params)


def evaluate_chunk(spec: SweepSpec, chunk: int) -> dict:
    """Evaluate chunk ``chunk`` of the sweep: a dict of arrays, one row per product row.

    pose (n, 3) m; k_a (n,) N m/rad; design (n, len(vary)) SI units, columns in the
    order of ``spec.vary``; freq_hz (n, n_modes) ascending, Hz; direction (n, n_modes)
    int8, index into ``AXES`` of each mode's largest eigentwist entry; reachable (n,)
    bool; pose_index (n,), case (n,) int64. Unreachable or singular rows have NaN
    frequencies, direction -1 and ``reachable=False``: they never stop the sweep.
    Deterministic: the same spec and chunk give the same bits in any process.
    """
    span = spec.chunk_rows(chunk)
    rows = np.arange(span.start, span.stop, dtype=np.int64)
    case, pose_index = np.divmod(rows, spec.n_poses)
    poses = spec.poses.take(pose_index)
    k_a, design = spec.case_values(case)
    params = {**dict(spec.fixed), "k_a": k_a, **{name: design[:, k] for k, name in enumerate(spec.design_names)}}
    ev = _evaluator(spec.robot, spec.backend)
    # invalid="nan": unreachable or singular rows are NaN and marked, never raise
    modes = ev.modes(poses, spec.model, invalid="nan", **params)
    reachable = np.ones(len(rows), bool) if modes.valid is None else np.asarray(modes.valid, bool)
    freq = modes.freq_hz
    direction = modes.direction.astype(np.int8)
    freq[~reachable] = np.nan
    direction[~reachable] = -1
    return {"pose": poses, "k_a": k_a, "design": design, "freq_hz": freq, "direction": direction,
            "reachable": reachable, "pose_index": pose_index, "case": case}


# ------------------------------------------------------------------- the summary
class LowestTracker:
    """Per case (design x k_a), the lowest mode-1 frequency over reachable poses.

    Updated chunk by chunk (memory: a few arrays of ``spec.n_cases``); ties go to the
    lowest pose index, so the result does not depend on the chunk order.
    """

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        c = spec.n_cases
        self.freq = np.full(c, np.nan)
        self.pose_index = np.full(c, -1, np.int64)
        self.direction = np.full(c, -1, np.int8)
        self.n_reachable = np.zeros(c, np.int64)

    def update(self, chunk: dict) -> None:
        f = chunk["freq_hz"][:, 0]
        ok = chunk["reachable"] & np.isfinite(f)
        case, f, pidx = chunk["case"][ok], f[ok], chunk["pose_index"][ok]
        if not len(case):
            return
        self.n_reachable += np.bincount(case, minlength=self.spec.n_cases)
        order = np.lexsort((pidx, f, case))
        first = order[np.r_[True, case[order][1:] != case[order][:-1]]]
        c, fc, pc = case[first], f[first], pidx[first]
        old_f, old_p = self.freq[c], self.pose_index[c]
        better = np.isnan(old_f) | (fc < old_f) | ((fc == old_f) & (pc < old_p))
        c = c[better]
        self.freq[c], self.pose_index[c] = fc[better], pc[better]
        self.direction[c] = chunk["direction"][ok][first][better, 0]

    def result(self) -> dict:
        """Arrays per case: case, k_a, design, freq_hz (NaN where no pose is reachable),
        pose (m) and pose_index where it occurs, direction (mode 1 there), n_reachable."""
        case = np.arange(self.spec.n_cases, dtype=np.int64)
        k_a, design = self.spec.case_values(case)
        pose = np.full((len(case), 3), np.nan)
        found = self.pose_index >= 0
        pose[found] = self.spec.poses.take(self.pose_index[found])
        return {"case": case, "k_a": k_a, "design": design, "freq_hz": self.freq.copy(), "pose": pose,
                "pose_index": self.pose_index.copy(), "direction": self.direction.copy(),
                "n_reachable": self.n_reachable.copy()}


def lowest(columns: dict, spec: SweepSpec) -> dict:
    """The :class:`LowestTracker` result of sweep columns already in memory
    (``load_sweep(path).columns`` or a concatenation of :func:`evaluate_chunk` results)."""
    tracker = LowestTracker(spec)
    tracker.update(columns)
    return tracker.result()


# ---------------------------------------------------------------------- engines
def _inprocess(spec: SweepSpec):
    for chunk in range(spec.n_chunks):
        yield chunk, evaluate_chunk(spec, chunk)


def _dask(spec: SweepSpec, scheduler: str | None = None, workers: int | None = None):
    """Submit the chunks to a Dask cluster; yield results in chunk order.

    A sliding window of ``2 x workers`` chunks in flight keeps memory bounded. The
    workers of a remote cluster need eigentwist installed (and a C compiler for
    ``backend="c"``); the spec travels with each task, each worker loads its evaluator once.
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:
        raise InputError(f'engine "dask" needs the optional dask extra: pip install "eigentwist[dask]" ({exc})') from None
    with ExitStack() as stack:
        if scheduler:
            client = stack.enter_context(Client(scheduler))
        else:
            cluster = stack.enter_context(LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                                       processes=True, dashboard_address=None))
            client = stack.enter_context(Client(cluster))
        window = 2 * max(1, len(client.scheduler_info().get("workers", {})))
        pending: deque = deque()
        submitted = 0
        while submitted < spec.n_chunks or pending:
            while submitted < spec.n_chunks and len(pending) < window:
                pending.append(client.submit(evaluate_chunk, spec, submitted, pure=False))
                submitted += 1
            index = submitted - len(pending)
            future = pending.popleft()
            result = future.result()
            future.release()
            yield index, result


@dataclass
class SweepSummary:
    """What :func:`run_sweep` reports: rows, reachable rows, wall time (s), the
    :func:`lowest` arrays and the backend actually used."""

    spec: SweepSpec
    n_rows: int
    n_reachable: int
    seconds: float
    lowest: dict
    backend: str = ""

    @property
    def rows_per_second(self) -> float:
        return self.n_rows / self.seconds if self.seconds > 0 else math.inf


def run_sweep(spec: SweepSpec, writer=None, engine: str = "inprocess", scheduler: str | None = None,
              workers: int | None = None, on_chunk=None) -> SweepSummary:
    """Evaluate every chunk of ``spec`` and stream it to ``writer`` (or nowhere).

    engine : ``"inprocess"`` or ``"dask"`` (``scheduler``: a Dask scheduler address;
        without one a ``LocalCluster`` of ``workers`` processes). Both give the same
        bits: chunks are deterministic and consumed in chunk order.
    on_chunk : called with ``(chunk_index, result)`` after each chunk (progress bars).
    """
    if engine not in ENGINES:
        raise InputError(f"engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if engine == "inprocess" and (scheduler or workers):
        raise InputError("scheduler and workers apply to the dask engine only")
    if scheduler and workers:
        raise InputError("workers sets the size of a local cluster: it cannot be combined with a scheduler address")
    start = time.perf_counter()
    tracker = LowestTracker(spec)
    reachable = 0
    results = _dask(spec, scheduler, workers) if engine == "dask" else _inprocess(spec)
    for index, result in results:
        if writer is not None:
            writer.write(index, result)
        tracker.update(result)
        reachable += int(result["reachable"].sum())
        if on_chunk is not None:
            on_chunk(index, result)
    summary = SweepSummary(spec, spec.n_rows, reachable, time.perf_counter() - start, tracker.result(),
                           _evaluator(spec.robot, spec.backend).backend)
    if writer is not None:
        writer.close(summary)
    return summary


# ---------------------------------------------------------------------- writers
def _manifest(spec: SweepSpec, complete: bool, backend: str = "", lowest_file: str | None = None) -> dict:
    return {"format": FORMAT, "version": 1, "spec": spec.to_dict(), "backend": backend,
            "n_rows": spec.n_rows, "n_chunks": spec.n_chunks, "n_modes": spec.n_modes, "axes": list(AXES),
            "design_names": list(spec.design_names), "complete": complete, "lowest": lowest_file,
            "units": {"pose": "m", "k_a": "N m/rad", "freq_hz": "Hz", "direction": "index into axes, -1: unreachable"}}


def _chunk_file(index: int) -> str:
    return f"chunk-{index:06d}.npz"


class NpzDirectoryWriter:
    """A directory: ``manifest.json``, one ``chunk-NNNNNN.npz`` per chunk, ``lowest.npz``.

    The manifest says ``"complete": false`` until :meth:`close`.
    """

    def __init__(self, path, spec: SweepSpec, overwrite: bool = False):
        self.path, self.spec = Path(path), spec
        if self.path.exists() and not self.path.is_dir():
            raise InputError(f"output {str(path)!r} exists and is not a directory: expected a directory for .npz chunks")
        ours = [p for p in self.path.glob("*") if p.name in (MANIFEST, LOWEST_FILE) or
                (p.name.startswith("chunk-") and p.suffix == ".npz")] if self.path.exists() else []
        if ours and not overwrite:
            raise InputError(f"output {str(path)!r} already holds a sweep: choose another path or overwrite it (--overwrite)")
        for p in ours:
            p.unlink()
        self.path.mkdir(parents=True, exist_ok=True)
        self._manifest(complete=False)

    def _manifest(self, **kwargs) -> None:
        text = json.dumps(_manifest(self.spec, **kwargs), indent=1)
        (self.path / MANIFEST).write_text(text + "\n")

    def write(self, index: int, result: dict) -> None:
        np.savez(self.path / _chunk_file(index), **result)

    def close(self, summary: SweepSummary) -> None:
        np.savez(self.path / LOWEST_FILE, **summary.lowest)
        self._manifest(complete=True, backend=summary.backend, lowest_file=LOWEST_FILE)


WIDE = {"freq_hz": "f{}_hz", "direction": "dir{}"}   # (n, modes) arrays as one column per mode


def _flat(columns: dict, spec: SweepSpec) -> dict:
    """Named 1-D columns for a table: x, y, z, k_a, <varied names>, f1_hz.., dir1.., and the rest."""
    out = {a: columns["pose"][:, k] for k, a in enumerate("xyz")}
    out["k_a"] = columns["k_a"]
    out.update({name: columns["design"][:, k] for k, name in enumerate(spec.design_names)})
    for key, val in columns.items():
        if key in ("pose", "k_a", "design"):
            continue
        if np.ndim(val) == 2:
            out.update({WIDE[key].format(j + 1): val[:, j] for j in range(val.shape[1])})
        else:
            out[key] = val
    return out


def _unflat(table: dict, spec: SweepSpec) -> dict:
    """The inverse of :func:`_flat`."""
    n = len(table["k_a"])
    out = {"pose": np.column_stack([table[a] for a in "xyz"]), "k_a": np.asarray(table["k_a"]),
           "design": np.column_stack([table[n_] for n_ in spec.design_names]) if spec.vary else np.empty((n, 0))}
    used = set("xyz") | {"k_a"} | set(spec.design_names)
    for key, pattern in WIDE.items():
        names = [pattern.format(j + 1) for j in range(spec.n_modes)]
        if names[0] in table:
            out[key] = np.column_stack([table[c] for c in names])
            used.update(names)
    out.update({k: np.asarray(v) for k, v in table.items() if k not in used})
    return out


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError as exc:
        raise InputError(f'Parquet output needs the optional parquet extra: pip install "eigentwist[parquet]" ({exc})') from None
    return pyarrow, pyarrow.parquet


def lowest_path(path) -> Path:
    """Where the :func:`lowest` table of a Parquet sweep goes: ``OUT.lowest.parquet``."""
    path = Path(path)
    return path.with_name(path.name[: -len(".parquet")] + ".lowest.parquet")


class ParquetWriter:
    """One Parquet file, one row group per chunk; the manifest in the schema metadata
    (key ``eigentwist.sweep``); the :func:`lowest` table beside it (:func:`lowest_path`)."""

    def __init__(self, path, spec: SweepSpec, overwrite: bool = False):
        self.pa, self.pq = _pyarrow()
        self.path, self.spec, self.writer = Path(path), spec, None
        if self.path.exists() and not overwrite:
            raise InputError(f"output {str(path)!r} already exists: choose another path or overwrite it (--overwrite)")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.manifest = _manifest(spec, complete=True, backend=_evaluator(spec.robot, spec.backend).backend,
                                  lowest_file=lowest_path(self.path).name)

    def _table(self, columns: dict, manifest: dict):
        table = self.pa.table(_flat(columns, self.spec))
        return table.replace_schema_metadata({"eigentwist.sweep": json.dumps(manifest)})

    def write(self, index: int, result: dict) -> None:
        table = self._table(result, self.manifest)
        if self.writer is None:
            self.writer = self.pq.ParquetWriter(str(self.path), table.schema)
        self.writer.write_table(table)

    def close(self, summary: SweepSummary) -> None:
        if self.writer is not None:
            self.writer.close()
        self.pq.write_table(self._table(summary.lowest, {"format": FORMAT + "-lowest"}), str(lowest_path(self.path)))


def open_writer(path, spec: SweepSpec, overwrite: bool = False):
    """A Parquet writer for ``*.parquet``, else an ``.npz`` directory writer."""
    if str(path).endswith(".parquet"):
        return ParquetWriter(path, spec, overwrite)
    return NpzDirectoryWriter(path, spec, overwrite)


# ---------------------------------------------------------------------- loading
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
        raise InputError(f"{str(path)!r} holds no {MANIFEST}: expected a directory written by eigentwist sweep") from None
    if manifest.get("format") != FORMAT:
        raise InputError(f"{str(path / MANIFEST)!r} is not an eigentwist sweep manifest")
    return manifest


def iter_chunks(path):
    """Yield ``(chunk_index, columns)`` of an ``.npz`` sweep directory, one chunk at a time."""
    path = Path(path)
    manifest = _read_manifest(path)
    for index in range(manifest["n_chunks"]):
        file = path / _chunk_file(index)
        if not file.exists():
            raise InputError(f"{str(file)!r} is missing: the sweep is incomplete ({index} of {manifest['n_chunks']} chunks)")
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
    columns = {k: np.concatenate([p[k] for p in parts]) for k in COLUMNS}
    low = None
    if manifest.get("lowest") and (path / manifest["lowest"]).exists():
        with np.load(path / manifest["lowest"]) as data:
            low = {k: data[k] for k in data.files}
    return SweepData(spec, manifest, columns, low)


def _load_parquet(path: Path) -> SweepData:
    _, pq = _pyarrow()
    if not path.exists():
        raise InputError(f"{str(path)!r} does not exist: expected a Parquet file written by eigentwist sweep")
    table = pq.read_table(str(path))
    meta = (table.schema.metadata or {}).get(b"eigentwist.sweep")
    if meta is None:
        raise InputError(f"{str(path)!r} is not an eigentwist sweep: no 'eigentwist.sweep' metadata")
    manifest = json.loads(meta)
    spec = SweepSpec.from_dict(manifest["spec"])
    columns = _unflat({k: table.column(k).to_numpy() for k in table.column_names}, spec)
    low = None
    if lowest_path(path).exists():
        t = pq.read_table(str(lowest_path(path)))
        low = _unflat({k: t.column(k).to_numpy() for k in t.column_names}, spec)
    return SweepData(spec, manifest, columns, low)
