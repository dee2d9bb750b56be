"""The sweep specification: poses in a box, k_a values, varied and fixed design parameters.

A sweep is the Cartesian product of designs (every combination of the varied design
parameters, the first one slowest) x k_a values (N m/rad) x poses (m, the fastest
index). Row ``i`` is ``pose_index = i % n_poses`` and ``case = i // n_poses`` with
``case = design_index * n_k_a + k_a_index``; a chunk is a block of consecutive rows
built by index arithmetic only, so the product is never materialised.

:func:`make_spec` validates everything against the robot's description before the first
chunk runs. It takes numbers only: parsing text such as ``"0.45:0.60:16"`` is the
command line's job (:mod:`eigentwist.cli.sweep_args`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import InputError
from ..evaluator import Evaluator
from .box import workspace_box
from .poseset import POSE_BLOCK, PoseSet

__all__ = [
    "PoseSet",
    "SweepSpec",
    "make_spec",
    "sweep_evaluator",
    "stiffness_parameter",
    "DEFAULT_CHUNK_SIZE",
    "POSE_BLOCK",
]

DEFAULT_CHUNK_SIZE = 65536  # rows per chunk: peak RSS about 400 MB (NumPy backend), 230 MB (C); measured


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
        """3 for a 3-DoF robot's rigid model (translational subset), else 6."""
        ev = sweep_evaluator(self.robot, self.backend)
        return ev.rigid_size() if ev.stiffness_model(self.model) == "rigid" else 6

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
        poses = {"sampling": self.poses.sampling, "box": [list(b) for b in self.poses.box]}
        poses.update(
            {"shape": list(self.poses.shape)}
            if self.poses.sampling == "grid"
            else {"n": self.poses.n, "seed": self.poses.seed}
        )
        return {
            "robot": self.robot,
            "backend": self.backend,
            "model": self.model,
            "poses": poses,
            "k_a": list(self.k_a),
            "vary": {name: list(v) for name, v in self.vary},
            "fixed": dict(self.fixed),
            "chunk_size": self.chunk_size,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "SweepSpec":
        p = d["poses"]
        poses = PoseSet(
            p["sampling"] if "sampling" in p else p["kind"],  # "kind": accepted as an alias
            tuple(tuple(b) for b in p["box"]),
            tuple(p.get("shape", ())),
            int(p.get("n", 0)),
            int(p.get("seed", 0)),
        )
        return cls(
            d["robot"],
            d["backend"],
            d["model"],
            poses,
            tuple(d["k_a"]),
            tuple((k, tuple(v)) for k, v in d["vary"].items()),
            tuple(d["fixed"].items()),
            int(d["chunk_size"]),
        )


@lru_cache(maxsize=None)
def sweep_evaluator(robot: str, backend: str) -> Evaluator:
    """One evaluator per process (a Dask worker loads its own)."""
    from ..loader import load

    return load(robot, backend=backend)


def _pose_set(grid, random, seed, box) -> PoseSet:
    if grid is not None and random is not None:
        raise InputError("poses: give a grid or a random sample, not both")
    if random is not None:
        if int(random) != random or random < 1:
            raise InputError(f"random sample size {random!r}: expected an integer >= 1")
        if int(seed) != seed or seed < 0:
            raise InputError(f"seed {seed!r}: expected an integer >= 0")
        return PoseSet("random", box, n=int(random), seed=int(seed))
    dim = len(box)
    shape = tuple(grid) if grid is not None else (5, 5, 5) if dim == 3 else (3,) * dim
    if dim > 3 and len(shape) == 3:
        shape += (1,) * (dim - 3)  # positions only: the rotation at the middle of its box
    if len(shape) != dim or any(int(s) != s or s < 1 for s in shape):
        raise InputError(
            f"grid {list(shape)}: expected {'three' if dim == 3 else dim} integers >= 1, one per pose "
            "coordinate" + (" (NX NY NZ)" if dim == 3 else "")
        )
    return PoseSet("grid", box, shape=tuple(int(s) for s in shape))


def _check_parameter(ev: Evaluator, name: str, values, what: str) -> None:
    if name not in ev.parameters:
        raise InputError(
            f"{what}: unknown parameter {name!r} for {ev.robot.name}: expected names from {', '.join(ev.parameters)}"
        )
    p = ev.parameters[name]
    for value in np.atleast_1d(np.asarray(values, dtype=float)).tolist():
        try:
            p.check(value)
        except ValueError as exc:
            expected = str(exc).partition(": expected ")[2] or "a value within the parameter's bounds"
            raise InputError(f"{what}: parameter {name!r} = {value!r} {p.unit}: expected {expected}") from None


def make_spec(
    robot: str = "heli4",
    *,
    model: str = "paper",
    backend: str = "numpy",
    grid=None,
    random=None,
    seed: int = 0,
    box=None,
    k_a=None,
    vary=(),
    fixed=None,
    chunk_size: int = DEFAULT_CHUNK_SIZE,
) -> SweepSpec:
    """Validate a sweep against the robot's description and return its :class:`SweepSpec`.

    grid : (nx, ny, nz) poses per axis (default (5, 5, 5) when ``random`` is None); a
        6-DoF robot takes six counts (default 3 per axis), or three: positions only, the
        rotation at the middle of its box;
    random, seed : a uniform sample of ``random`` poses, reproducible from ``seed``;
    box : six numbers XLO XHI YLO YHI ZLO ZHI (m), default the robot's workspace; a
        6-DoF robot takes twelve, its rotation vector's ranges in rad last;
    k_a : values in N m/rad (a number or a sequence), default the description's;
    vary : ``{name: values}`` or ``[(name, values)]`` in SI units, first slowest;
    fixed : ``{name: value}`` for every row.

    Every name, bound and option is checked here, so that a sweep fails before its
    first chunk; errors name the value and what was expected.
    """
    from ...description.effects import resolve_model

    ev = sweep_evaluator(robot, backend)
    try:
        resolve_model(model, ev.robot)
    except ValueError as exc:
        raise InputError(f"model {model!r}: {exc}") from None
    poses = _pose_set(grid, random, seed, workspace_box(box, ev.robot))
    name_k = stiffness_parameter(ev, robot)
    k_a = (ev.defaults[name_k],) if k_a is None else _numbers(k_a, "k_a")
    _check_parameter(ev, name_k, k_a, "k_a")
    pairs = tuple(_vary_pairs(vary))
    fixed = tuple((str(k), float(v)) for k, v in dict(fixed or {}).items())
    names = [n for n, _ in pairs]
    for name, values in pairs:
        if name == "k_a":
            raise InputError("varied parameter k_a: k_a has its own argument: pass its values as k_a=...")
        if names.count(name) > 1:
            raise InputError(f"varied parameter {name!r}: given more than once")
        if name in dict(fixed):
            raise InputError(f"{name}: both varied and fixed: give it once")
        _check_parameter(ev, name, values, f"varied parameter {name!r}")
    for name, value in fixed:
        if name == "k_a":
            raise InputError("fixed parameter k_a: k_a has its own argument: pass its values as k_a=...")
        _check_parameter(ev, name, value, f"fixed parameter {name}={value:g}")
    if int(chunk_size) != chunk_size or chunk_size < 1:
        raise InputError(f"chunk size {chunk_size!r}: expected an integer number of rows >= 1")
    return SweepSpec(robot, backend, model, poses, k_a, pairs, fixed, int(chunk_size))


def stiffness_parameter(ev, robot=None) -> str:
    """The parameter a sweep's ``k_a`` column sets: ``k_a``, or the robot's shared actuator
    stiffness where its legs differ (an RRR-RRR-PRR's ``k_r``); ``InputError`` else."""
    if "k_a" in ev.parameters:
        return "k_a"
    shared = str(getattr(ev.robot, "actuator_stiffness", ""))
    if shared in ev.parameters:
        return shared
    raise InputError(f"robot {robot or ev.robot.name!r} has no parameter 'k_a': a sweep needs the actuator stiffness")


def _vary_pairs(vary):
    items = vary.items() if isinstance(vary, dict) else vary
    for item in items:
        try:
            name, values = item
        except (TypeError, ValueError):
            raise InputError(f"varied parameter {item!r}: expected a (name, values) pair") from None
        yield str(name), _numbers(values, f"varied parameter {name!r}")


def _numbers(values, what: str) -> tuple[float, ...]:
    """A number or a sequence of numbers as a tuple of finite floats (errors name ``what``)."""
    if isinstance(values, str):
        raise InputError(f"{what}: {values!r} is text: expected numbers (the command line parses text)")
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=float))
    except (TypeError, ValueError):
        raise InputError(f"{what}: {values!r}: expected a number or a sequence of numbers") from None
    if arr.ndim != 1 or arr.size == 0 or not np.isfinite(arr).all():
        raise InputError(f"{what}: {np.asarray(values).tolist()!r}: expected one or more finite numbers")
    return tuple(float(v) for v in arr)
