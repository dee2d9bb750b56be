"""Load a generated evaluator: ``load("heli4", backend="numpy" | "c" | "auto")``.

``robot`` may also be the path of a user's description file (``"my_heli4.py"``, which
defines ``describe()``) or a :class:`~eigentwist.description.RobotDescription`: its
evaluators are generated on first use into the cache (:mod:`.userfile`).
"""

from __future__ import annotations

import importlib
import warnings

from ..description.names import did_you_mean
import sys
from pathlib import Path

from ..generated import generated_name
from ..robots import NAMES, get
from .ccompile import read_shipped
from .errors import InputError
from .evaluator import Evaluator
from .threads import resolve_threads
from .userfile import (
    describe_file,
    description_key,
    generated_modules,
    import_numpy_module,
    is_description,
    is_description_file,
)

__all__ = ["load", "load_module", "evaluator_from_description", "BACKENDS"]

BACKENDS = ("numpy", "c", "auto")


def load_module(robot: str, backend: str = "numpy"):
    """Import the generated module ``eigentwist.generated.<robot>_<backend>``, checked
    first against its recorded SHA-256 (:func:`~.ccompile.read_shipped`)."""
    from .. import generated

    name = generated_name(robot, backend)
    read_shipped(Path(generated.__file__).parent / name)
    return importlib.import_module("eigentwist.generated." + Path(name).stem)


class _GenerationProgress:
    """The default ``progress`` of :func:`load`: while a description is generated, a tqdm
    bar on stderr whose label is the current step (derive, CSE of each kernel); one line
    per step when stderr is not a terminal (logs, pipes)."""

    def __init__(self):
        self.bar = None

    def __call__(self, message: str) -> None:
        if not sys.stderr.isatty():
            print(f"[eigentwist] {message}", file=sys.stderr, flush=True)
            return
        from tqdm.auto import tqdm

        if self.bar is None:
            self.bar = tqdm(file=sys.stderr, unit="step", desc="[eigentwist] generating", leave=False)
        self.bar.set_description(f"[eigentwist] {message.strip()[:70]}")
        self.bar.update(1)
        if message.startswith("generated "):
            self.bar.close()
            self.bar = None
            print(f"[eigentwist] {message}", file=sys.stderr, flush=True)


_stderr = _GenerationProgress()


def load(robot="heli4", backend: str = "auto", threads: int | None = None, progress=_stderr) -> Evaluator:
    """An :class:`Evaluator` for ``robot``: a name from ``eigentwist.robots.NAMES``, the
    path of a Python file whose ``describe()`` returns a description, or a description
    (:class:`~eigentwist.description.RobotDescription`, or a joint-list
    :class:`~eigentwist.description.chain.ChainRobot`).

    ``backend="numpy"`` uses the generated NumPy module; ``"c"`` the generated C source
    compiled with the system compiler (cached by content hash); ``"auto"`` tries C and
    falls back to NumPy with one warning when no compiler is available. A description
    that is not shipped is generated on first use into the cache, keyed by its content;
    ``progress(message)`` reports the steps (default: stderr).

    ``threads`` (C backend): how many threads one batch may use. None: the
    ``EIGENTWIST_THREADS`` environment variable, else 1 inside a Dask worker, else every
    core; a batch of fewer than 16 blocks of 64 poses per thread uses fewer threads.
    Results are bit-identical whatever the count.
    """
    if backend not in BACKENDS:
        raise InputError(f"unknown backend {backend!r}: expected one of {', '.join(BACKENDS)}")
    if threads is not None:
        resolve_threads(threads)  # a bad value is an error on every backend
    if is_description_file(robot) or is_description(robot):
        return _load_user(robot, backend, threads, progress)
    if robot not in NAMES:
        raise InputError(
            f"unknown robot {robot!r}{did_you_mean(str(robot), NAMES)}: expected one of {', '.join(NAMES)} "
            "or a description file PATH.py"
        )
    return _with_backend(get(robot), load_module(robot, "numpy"), backend, robot, threads)


def _load_user(robot, backend: str, threads, progress) -> Evaluator:
    if is_description(robot):
        description, extra, spec = robot, b"", robot.name
    else:
        description = describe_file(robot)
        extra, spec = Path(robot).read_bytes(), str(robot)
    key = description_key(description, extra)
    directory, texts = generated_modules(
        description, key, progress, ("numpy",) if backend == "numpy" else ("numpy", "c")
    )
    name = generated_name(description.name, "numpy")
    module = import_numpy_module(texts[name], directory / name)
    source = texts.get(generated_name(description.name, "c"))
    ev = _with_backend(description, module, backend, description.name, threads, source)
    ev.spec = spec
    return ev


def _with_backend(description, module, backend: str, robot: str, threads, source: str | None = None) -> Evaluator:
    if backend == "numpy":
        return Evaluator(description, module, "numpy", threads=threads)
    try:
        from .c_kernels import load_c_kernels
    except ImportError:
        load_c_kernels = None
    if load_c_kernels is None:
        if backend == "c":
            raise InputError("the C backend is not available in this build")
        return Evaluator(description, module, "numpy")
    try:
        kernels = load_c_kernels(robot, module, source)
    except Exception as exc:  # compiler missing or failing: reported, never swallowed silently
        if backend == "c":
            raise
        warnings.warn(f"eigentwist: C backend unavailable ({exc}); falling back to NumPy", RuntimeWarning, stacklevel=2)
        return Evaluator(description, module, "numpy", threads=threads)
    return Evaluator(description, module, "c", kernels=kernels, threads=threads)


def evaluator_from_description(description, progress=None) -> Evaluator:
    """Derive, generate and load a NumPy evaluator for ``description`` in memory.

    For design studies on a modified description (``dataclasses.replace`` of a shipped
    one): nothing is written to ``eigentwist/generated``. Takes a few seconds (derivation
    and CSE).
    """
    import types

    from ..codegen.generate import render_robot

    files = render_robot(description, progress=progress, backends=("numpy",))
    (text,) = files.values()
    module = types.ModuleType(f"eigentwist_generated_{description.name}_inmemory")
    exec(compile(text, module.__name__, "exec"), module.__dict__)
    return Evaluator(description, module, "numpy")
